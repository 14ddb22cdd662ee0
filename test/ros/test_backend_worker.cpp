// The worker thread with a recording output instead of the nodelet's
// publishers: what it publishes, in which order (no ROS master needed).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <mutex>
#include <thread>
#include <vector>

#include <ros/time.h>

#include "agnc_pgo/ros/backend_worker.h"

namespace agnc_pgo {
namespace ros_backend {
namespace {

struct Event {
  enum Kind { kEstimate, kStatus } kind;
  unsigned first_estimates = 0;
  bool refining = false;
  int nodes = 0;
};

class RecordingOutput : public BackendOutput {
 public:
  void publishEstimate(const GraphSnapshot&) override { add({Event::kEstimate}); }
  void publishGraph(const GraphSnapshot&) override {}
  void publishStatus(const StatusInfo& s) override {
    add({Event::kStatus, s.counters.first_estimates, s.refining, s.nodes});
  }
  void publishKeyframe(int, const ros::Time&, const core::Pose&) override {}

  std::vector<Event> events() {
    std::lock_guard<std::mutex> lock(mutex_);
    return events_;
  }
  void clear() {
    std::lock_guard<std::mutex> lock(mutex_);
    events_.clear();
  }

 private:
  void add(const Event& e) {
    std::lock_guard<std::mutex> lock(mutex_);
    events_.push_back(e);
  }
  std::mutex mutex_;
  std::vector<Event> events_;
};

ros::Time stampOf(int i) { return ros::Time(1.0 + 0.1 * i); }

// Waits (at most 20 s) until a status satisfies `done`.
template <typename Done>
bool waitForStatus(RecordingOutput* output, Done done) {
  for (int k = 0; k < 400; ++k) {
    for (const Event& e : output->events())
      if (e.kind == Event::kStatus && done(e)) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return false;
}

// A corridor driven straight, whose odometry turns 2e-4 rad a step too
// much, and a loop closure over 159 of its 260 poses that straightens it:
// the window (the last 200 poses) takes the correction and the older poses
// must follow, so the update publishes a first estimate before refining
// the whole graph.
TEST(BackendWorker, StatusSaysRefiningBetweenTheFirstEstimateAndTheEndOfTheUpdate) {
  ros::Time::init();
  BackendParameters parameters;
  parameters.dimension = 2;
  RecordingOutput output;
  BackendWorker worker(parameters, &output);
  worker.start();
  const int poses = 260;
  core::Pose odom = core::Pose::identity();
  for (int i = 0; i < poses; ++i) {
    if (i > 0) odom = odom * core::Pose::fromSE2(1.0, 0.0, 2e-4);
    worker.enqueueOdometry(OdometryInput{stampOf(i), odom, Eigen::MatrixXd()});
  }
  ASSERT_TRUE(waitForStatus(&output, [&](const Event& e) { return e.nodes == poses; }));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the graph published at idle
  output.clear();

  LoopClosureInput loop;
  loop.from_stamp = stampOf(100);
  loop.to_stamp = stampOf(poses - 1);
  loop.measurement = core::Pose::fromSE2(poses - 1 - 100, 0.0, 0.0);
  loop.information = Eigen::Vector3d(1.0, 1.0, 100.0).asDiagonal();  // sigma 1 m, 0.1 rad
  loop.source = "true";
  loop.received = BackendWorker::now();
  worker.enqueueLoopClosure(loop);
  ASSERT_TRUE(waitForStatus(&output, [](const Event& e) { return e.first_estimates == 1 && !e.refining; }))
      << "the update published no first estimate, or never finished";
  worker.stop();

  // The first status that counts the first estimate comes right after it,
  // says the estimate will still move, and precedes the update's last
  // estimate; a later one says the update has ended.
  const std::vector<Event> events = output.events();
  int estimates_before = 0;
  size_t first_status = events.size();
  for (size_t k = 0; k < events.size(); ++k) {
    if (events[k].kind == Event::kEstimate) ++estimates_before;
    if (events[k].kind == Event::kStatus && events[k].first_estimates == 1) {
      first_status = k;
      break;
    }
  }
  ASSERT_LT(first_status, events.size());
  EXPECT_EQ(estimates_before, 1);
  EXPECT_TRUE(events[first_status].refining);
  int estimates_after = 0;
  for (size_t k = first_status + 1; k < events.size(); ++k) estimates_after += events[k].kind == Event::kEstimate;
  EXPECT_GE(estimates_after, 1);
}

}  // namespace
}  // namespace ros_backend
}  // namespace agnc_pgo
