// The worker thread: the only owner of the BackendGraph. ROS callbacks push
// validated inputs and commands into its queue; it processes them in order,
// runs the engine on every batch of new loop closures, and hands snapshots to
// the output (publishers). Service calls wait for their command's result.
#pragma once

#include <condition_variable>
#include <deque>
#include <functional>
#include <map>
#include <future>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "agnc_pgo/ros/backend_graph.h"
#include "agnc_pgo/ros/latency_histogram.h"

namespace agnc_pgo {
namespace ros_backend {

struct StatusInfo {
  int nodes = 0, odometry_edges = 0, loop_closures = 0, inliers = 0, outliers = 0, graduating = 0;
  int held = 0;
  Counters counters;
  ros::Time last_update;
  long total_gnc_steps = 0, total_iterations = 0;
  double latency_p50 = 0, latency_p95 = 0, latency_max = 0;
  double first_latency_p50 = 0, first_latency_p95 = 0, first_latency_max = 0;  // to the first estimate
  // IncrementalGnc::noiseScale(), per block (1 = covariances as stated).
  double noise_scale_translation = 1.0, noise_scale_rotation = 1.0;
  bool paused = false;
  // The estimate will still move: an update that published its first
  // estimate is finishing (anytime), or an idle refinement is under way
  // (BackendGraph::refining()).
  bool refining = false;
};

// Implemented by the nodelet (publishers). Called from the worker thread.
class BackendOutput {
 public:
  virtual ~BackendOutput() = default;
  virtual void publishEstimate(const GraphSnapshot& nodes_only) = 0;  // ~path
  virtual void publishGraph(const GraphSnapshot& full) = 0;           // ~markers, ~pose_graph
  virtual void publishStatus(const StatusInfo& status) = 0;           // ~status
  virtual void publishKeyframe(int id, const ros::Time& stamp, const core::Pose& estimate) = 0;  // ~keyframes
};

struct CommandResult {
  bool success = false;
  std::string message;
};

class BackendWorker {
 public:
  BackendWorker(const BackendParameters& parameters, BackendOutput* output);
  ~BackendWorker();
  BackendWorker(const BackendWorker&) = delete;
  BackendWorker& operator=(const BackendWorker&) = delete;

  void start();
  void stop();

  // From callbacks (any thread). Inputs are validated already.
  void enqueueOdometry(const OdometryInput& input);
  void enqueueLoopClosure(const LoopClosureInput& input);
  void rejectOdometry(const std::string& reason);
  void rejectLoopClosure(const std::string& reason);

  // Services: run on the worker thread, wait for the result.
  CommandResult saveGraph(const std::string& filename);
  CommandResult loadGraph(const std::string& filename);
  CommandResult saveTrajectory(const std::string& filename);
  CommandResult optimize();
  CommandResult reset();
  CommandResult setPaused(bool paused);
  // dynamic_reconfigure: `next` (validated; readRuntimeParameters) takes
  // effect on the worker thread, in order with the messages before it, and
  // is logged. Does not wait.
  void reconfigure(const BackendParameters& next);
  CommandResult setLoopClosureStatus(int index, core::LoopOverride mode);
  // The same, addressed by the stamps of the loop closure's keyframes.
  CommandResult setLoopClosureStatus(const ros::Time& from_stamp, const ros::Time& to_stamp,
                                     core::LoopOverride mode);

  // Latest map -> odom (thread-safe).
  core::Pose mapToOdom() const;
  // Seconds (steady clock) used for latency stamps.
  static double now();

 private:
  struct Item {
    enum class Kind { kOdometry, kLoopClosure, kCommand } kind;
    OdometryInput odometry;
    LoopClosureInput loop;
    std::function<CommandResult()> command;
    std::shared_ptr<std::promise<CommandResult>> result;
  };

  CommandResult call(std::function<CommandResult()> command);
  // Queues a command without waiting for it.
  void post(std::function<CommandResult()> command);
  void push(Item item);
  void run();
  void processBatch(std::deque<Item>* batch);
  void refineWhileIdle();
  // processBatch()'s steps; each returns whether it added to the graph
  // (a keyframe, a loop closure), warning about and counting what it rejected.
  bool processOdometry(const OdometryInput& odometry);
  bool processLoopClosure(const LoopClosureInput& loop);
  void runCommand(Item* item);
  bool retryHeldLoopClosures();
  // Counts a rejected message in `counter` and warns (throttled) why.
  void reject(unsigned Counters::*counter, const std::string& message);
  void solve();
  // Logs the engine's noise scale when it has risen since last logged.
  void reportNoiseScale();
  void publish(bool force_graph);
  // The anytime first estimate of an update (~path, map -> odom).
  void publishFirstEstimate();
  void publishStatus();
  StatusInfo status() const;
  // Logs a warning, throttled per kind (the text before its first ':'): at
  // most one line per kind every kWarningInterval seconds, saying how many
  // like it were not logged. Every one is counted in ~status regardless.
  void warn(const std::string& message);
  CommandResult applyOverride(int index, core::LoopOverride mode);

  BackendParameters parameters_;  // worker thread only (runtime ones change by reconfigure())
  const int max_queue_;           // read by push() on the callbacks' threads
  BackendOutput* output_;
  BackendGraph graph_;  // worker thread only

  mutable std::mutex queue_mutex_;
  std::condition_variable queue_cv_;
  std::deque<Item> queue_;
  bool stopping_ = false;
  std::thread thread_;

  mutable std::mutex counters_mutex_;  // counters written by callbacks and the worker
  Counters counters_;

  mutable std::mutex map_to_odom_mutex_;
  core::Pose map_to_odom_;

  // Worker thread only.
  bool paused_ = false;
  bool graph_dirty_ = false;
  bool needs_update_ = false;
  double last_activity_ = -1e9;  // when the worker last finished a non-empty batch [s, now()]
  double idle_iteration_s_ = 0.0;  // how long the last idle iteration took
  double last_graph_publish_ = -1e9;
  double last_status_publish_ = -1e9;
  ros::Time last_update_;
  std::vector<double> pending_latency_;  // receive times of loop closures not yet published
  LatencyHistogram latencies_ms_;  // bounded: a status costs O(1) however long the run
  LatencyHistogram first_latencies_ms_;  // receive -> first estimate published
  bool first_published_ = false;         // in the update running now
  bool finishing_update_ = false;        // ... and it is still running (the status says so)
  // The noise scale last logged: a rise is logged once (it is re-estimated
  // only as the loop closures double, so rarely).
  double logged_noise_translation_ = 1.0, logged_noise_rotation_ = 1.0;

  struct WarningThrottle {
    double last_logged = -1e9;
    int suppressed = 0;
  };
  std::map<std::string, WarningThrottle> warning_throttle_;  // by kind; guarded by counters_mutex_
};

}  // namespace ros_backend
}  // namespace agnc_pgo
