#include "agnc_pgo/ros/backend_worker.h"

#include <algorithm>
#include <chrono>
#include <sstream>

#include <ros/console.h>

#include "agnc_pgo/core/trajectory_io.h"
#include "agnc_pgo/core/statistics.h"

namespace agnc_pgo {
namespace ros_backend {

namespace {
constexpr double kCommandTimeout = 120.0;  // [s] a service waits this long for the worker
constexpr double kWarningInterval = 5.0;   // [s] at most one logged warning of a kind per interval
}

BackendWorker::BackendWorker(const BackendParameters& parameters, BackendOutput* output)
    : parameters_(parameters),
      max_queue_(parameters.max_queue),
      output_(output),
      graph_(parameters),
      paused_(parameters.paused) {}

BackendWorker::~BackendWorker() { stop(); }

double BackendWorker::now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

void BackendWorker::start() {
  std::lock_guard<std::mutex> lock(queue_mutex_);
  if (thread_.joinable()) return;
  stopping_ = false;
  thread_ = std::thread(&BackendWorker::run, this);
}

void BackendWorker::stop() {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    stopping_ = true;
  }
  queue_cv_.notify_all();
  if (thread_.joinable()) thread_.join();
  // Unblock any service still waiting.
  std::lock_guard<std::mutex> lock(queue_mutex_);
  for (Item& item : queue_)
    if (item.result) item.result->set_value({false, "the back-end is shutting down"});
  queue_.clear();
}

void BackendWorker::warn(const std::string& message) {
  const double t = now();
  std::lock_guard<std::mutex> lock(counters_mutex_);
  counters_.last_warning = message;
  WarningThrottle& throttle = warning_throttle_[message.substr(0, message.find(':'))];
  if (t - throttle.last_logged < kWarningInterval) {
    ++throttle.suppressed;
    return;
  }
  if (throttle.suppressed > 0)
    ROS_WARN_STREAM("agnc_pgo: " << message << " (and " << throttle.suppressed << " more like it in the last "
                                 << static_cast<int>(t - throttle.last_logged) << " s, counted in ~status)");
  else
    ROS_WARN_STREAM("agnc_pgo: " << message);
  throttle.last_logged = t;
  throttle.suppressed = 0;
}

void BackendWorker::rejectOdometry(const std::string& reason) {
  {
    std::lock_guard<std::mutex> lock(counters_mutex_);
    ++counters_.odometry_messages;
    ++counters_.rejected_odometry;
  }
  warn("rejected odometry: " + reason);
}

void BackendWorker::rejectLoopClosure(const std::string& reason) {
  {
    std::lock_guard<std::mutex> lock(counters_mutex_);
    ++counters_.loop_closure_messages;
    ++counters_.rejected_loop_closures;
  }
  warn("rejected loop closure: " + reason);
}

void BackendWorker::push(Item item) {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    if (static_cast<int>(queue_.size()) >= max_queue_ && item.kind != Item::Kind::kCommand) {
      // Fall through to the rejection below (outside the lock).
    } else {
      queue_.push_back(std::move(item));
      queue_cv_.notify_one();
      return;
    }
  }
  if (item.kind == Item::Kind::kOdometry) rejectOdometry("worker queue full (~max_queue)");
  else rejectLoopClosure("worker queue full (~max_queue)");
}

void BackendWorker::enqueueOdometry(const OdometryInput& input) {
  {
    std::lock_guard<std::mutex> lock(counters_mutex_);
    ++counters_.odometry_messages;
  }
  Item item{Item::Kind::kOdometry, input, {}, {}, {}};
  push(std::move(item));
}

void BackendWorker::enqueueLoopClosure(const LoopClosureInput& input) {
  {
    std::lock_guard<std::mutex> lock(counters_mutex_);
    ++counters_.loop_closure_messages;
  }
  Item item{Item::Kind::kLoopClosure, {}, input, {}, {}};
  push(std::move(item));
}

CommandResult BackendWorker::call(std::function<CommandResult()> command) {
  auto promise = std::make_shared<std::promise<CommandResult>>();
  std::future<CommandResult> future = promise->get_future();
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    if (stopping_) return {false, "the back-end is shutting down"};
    queue_.push_back(Item{Item::Kind::kCommand, {}, {}, std::move(command), promise});
  }
  queue_cv_.notify_one();
  if (future.wait_for(std::chrono::duration<double>(kCommandTimeout)) != std::future_status::ready)
    return {false, "timed out waiting for the back-end worker"};
  return future.get();
}

void BackendWorker::post(std::function<CommandResult()> command) {
  auto nobody_waits = std::make_shared<std::promise<CommandResult>>();
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    if (stopping_) return;
    queue_.push_back(Item{Item::Kind::kCommand, {}, {}, std::move(command), nobody_waits});
  }
  queue_cv_.notify_one();
}

core::Pose BackendWorker::mapToOdom() const {
  std::lock_guard<std::mutex> lock(map_to_odom_mutex_);
  return map_to_odom_;
}

void BackendWorker::run() {
  while (true) {
    std::deque<Item> batch;
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      // While the idle refinement has work, wait only until the gap is long
      // enough for an iteration (refineWhileIdle()).
      const double period = std::min(0.05, 1.0 / parameters_.status_rate);
      const bool refining = !paused_ && graph_.refining();
      const double wait =
          refining ? std::max(0.0, std::min(period, last_activity_ + idle_iteration_s_ - now())) : period;
      queue_cv_.wait_for(lock, std::chrono::duration<double>(wait),
                         [this] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      batch.swap(queue_);
    }
    try {
      processBatch(&batch);
      const bool idle = batch.empty();
      if (idle) refineWhileIdle();
      else last_activity_ = now();
      const double t = now();
      if (graph_dirty_ && (idle || t - last_graph_publish_ >= 1.0 / parameters_.visualization_rate))
        publish(true);
      if (t - last_status_publish_ >= 1.0 / parameters_.status_rate) publishStatus();
    } catch (const std::exception& e) {
      // Nothing may take the nodelet down; the graph methods keep it consistent.
      warn(std::string("worker error: ") + e.what());
    }
  }
}

void BackendWorker::refineWhileIdle() {
  // An update leaves the whole graph near convergence, not at it (it
  // refines only once its windows have moved enough); with nothing queued,
  // one iteration at a time brings it there, so a message that arrives
  // waits for at most one. An iteration starts only in a gap at least as
  // long as the last one took: a stream of messages closer than that (a
  // 200 Hz front-end on a large map) is not delayed, and the refinement
  // runs when it pauses. The result is published once converged.
  if (paused_ || needs_update_) return;
  if (now() - last_activity_ < idle_iteration_s_) return;
  std::string error;
  const double start = now();
  if (!graph_.refineIdle(&error)) {
    if (!error.empty()) warn(error);  // rolled back; the loop publishes the dirty graph
    graph_dirty_ = graph_dirty_ || !error.empty();
    return;
  }
  idle_iteration_s_ = now() - start;
  if (graph_.refining()) return;  // not converged yet
  {
    std::lock_guard<std::mutex> lock(counters_mutex_);
    ++counters_.idle_refinements;
  }
  graph_dirty_ = true;
  publish(true);
}

void BackendWorker::processBatch(std::deque<Item>* batch) {
  bool changed = false;  // keyframes or (paused) loop closures added
  for (Item& item : *batch) {
    switch (item.kind) {
      case Item::Kind::kOdometry: changed |= processOdometry(item.odometry); break;
      case Item::Kind::kLoopClosure: changed |= processLoopClosure(item.loop); break;
      case Item::Kind::kCommand: runCommand(&item); break;
    }
  }
  changed |= retryHeldLoopClosures();
  if (needs_update_ && !paused_) {
    solve();
  } else if (changed) {
    graph_dirty_ = true;
    publish(false);
  }
}

bool BackendWorker::processOdometry(const OdometryInput& odometry) {
  bool keyframe = false;
  const std::string warning = graph_.addOdometry(odometry, &keyframe);
  if (!warning.empty()) reject(&Counters::rejected_odometry, "rejected odometry: " + warning);
  if (keyframe) {
    const int id = graph_.numNodes() - 1;
    output_->publishKeyframe(id, graph_.stamps()[id], graph_.engine()->pose(id));
  }
  return keyframe;
}

bool BackendWorker::processLoopClosure(const LoopClosureInput& loop) {
  bool added = false;
  const std::string warning = graph_.addLoopClosure(loop, &added);
  if (!warning.empty()) reject(&Counters::rejected_loop_closures, "rejected loop closure: " + warning);
  if (added) {
    pending_latency_.push_back(loop.received);
    needs_update_ = true;
  }
  return added;
}

void BackendWorker::reject(unsigned Counters::*counter, const std::string& message) {
  {
    std::lock_guard<std::mutex> lock(counters_mutex_);
    ++(counters_.*counter);
  }
  warn(message);
}

void BackendWorker::runCommand(Item* item) {
  // Bring the graph up to date first so commands see every earlier message.
  if (needs_update_ && !paused_) solve();
  CommandResult result;
  try {
    result = item->command();
  } catch (const std::exception& e) {
    result = {false, e.what()};
  }
  item->result->set_value(result);
  graph_dirty_ = true;
  publish(true);
  publishStatus();
}

bool BackendWorker::retryHeldLoopClosures() {
  // Held loop closures whose keyframes may have arrived; drop expired ones.
  if (graph_.heldLoopClosures() == 0) return false;
  std::vector<double> added;
  for (const std::string& warning : graph_.retryHeld(now(), &added)) {
    const bool dropped = warning.find("dropped") != std::string::npos;
    {
      std::lock_guard<std::mutex> lock(counters_mutex_);
      ++counters_.rejected_loop_closures;
      if (dropped) ++counters_.dropped_loop_closures;
    }
    warn((dropped ? "dropped loop closure: " : "rejected loop closure: ") + warning);
  }
  if (added.empty()) return false;
  pending_latency_.insert(pending_latency_.end(), added.begin(), added.end());
  needs_update_ = true;
  return true;
}

void BackendWorker::solve() {
  needs_update_ = false;
  core::UpdateStats stats;
  std::string error;
  const double start = now();
  first_published_ = false;
  const bool ok = graph_.update(&stats, &error, [this] { publishFirstEstimate(); });
  finishing_update_ = false;
  const double end = now();
  {
    std::lock_guard<std::mutex> lock(counters_mutex_);
    counters_.last_update_ms = (end - start) * 1e3;
    counters_.last_gnc_steps = static_cast<unsigned>(stats.gnc_steps);
    if (!ok) ++counters_.failed_updates;
  }
  if (!ok) warn(error);
  reportNoiseScale();
  last_update_ = ros::Time::now();
  graph_dirty_ = true;
  publish(false);
  const double published = now();
  for (double received : pending_latency_) {
    latencies_ms_.add((published - received) * 1e3);
    if (!first_published_) first_latencies_ms_.add((published - received) * 1e3);
  }
  pending_latency_.clear();
}

void BackendWorker::reportNoiseScale() {
  const Eigen::VectorXd& scale = graph_.engine()->noiseScale();
  const double translation = scale(0), rotation = scale(scale.size() - 1);
  if (translation > logged_noise_translation_ || rotation > logged_noise_rotation_)
    ROS_WARN_STREAM("agnc_pgo: the loop closures show more noise than the covariances state; every covariance "
                    "is widened: translation variances x"
                    << translation << ", rotation x" << rotation
                    << " (~status noise_scale_*; the front-end's covariances are too tight)");
  // A fall (the engine's later estimate, or a replaced graph) is not
  // logged, only remembered, so the next rise is measured from it.
  logged_noise_translation_ = translation;
  logged_noise_rotation_ = rotation;
}

void BackendWorker::publishFirstEstimate() {
  // The window holds the update's correction; the rest of the update (the
  // whole graph following it) does not change it much, and can take long on
  // a large map. If the update fails after this, its end publishes the last
  // good estimate again.
  publish(false);
  const double published = now();
  for (double received : pending_latency_) first_latencies_ms_.add((published - received) * 1e3);
  first_published_ = true;
  {
    std::lock_guard<std::mutex> lock(counters_mutex_);
    ++counters_.first_estimates;
  }
  // Anytime, said in ~status: a subscriber learns that this estimate is a
  // first one and the update goes on (refining until it ends).
  finishing_update_ = true;
  publishStatus();
}

void BackendWorker::publish(bool full) {
  {
    std::lock_guard<std::mutex> lock(map_to_odom_mutex_);
    map_to_odom_ = graph_.mapToOdom();
  }
  GraphSnapshotPtr snapshot = graph_.snapshot(full);
  output_->publishEstimate(*snapshot);
  if (full) {
    output_->publishGraph(*snapshot);
    last_graph_publish_ = now();
    graph_dirty_ = false;
    publishStatus();
  }
}

StatusInfo BackendWorker::status() const {
  StatusInfo s;
  const core::IncrementalGnc* engine = graph_.engine();
  s.nodes = engine->numPoses();
  s.odometry_edges = static_cast<int>(engine->odometry().size());
  const auto& loops = engine->loopClosures();
  s.loop_closures = static_cast<int>(loops.size());
  const int first_pending = s.loop_closures - engine->pendingLoopClosures();
  for (int k = 0; k < s.loop_closures; ++k) {
    if (loops[k].graduation.graduating || k >= first_pending) ++s.graduating;
    else if (loops[k].inlier) ++s.inliers;
    else ++s.outliers;
  }
  s.held = graph_.heldLoopClosures();
  {
    std::lock_guard<std::mutex> lock(counters_mutex_);
    s.counters = counters_;
  }
  s.last_update = last_update_;
  s.total_gnc_steps = graph_.totalGncSteps();
  s.total_iterations = graph_.totalIterations();
  s.latency_p50 = latencies_ms_.percentile(50);
  s.latency_p95 = latencies_ms_.percentile(95);
  s.latency_max = latencies_ms_.max();
  s.first_latency_p50 = first_latencies_ms_.percentile(50);
  s.first_latency_p95 = first_latencies_ms_.percentile(95);
  s.first_latency_max = first_latencies_ms_.max();
  const Eigen::VectorXd& scale = engine->noiseScale();
  s.noise_scale_translation = scale(0);
  s.noise_scale_rotation = scale(scale.size() - 1);
  s.paused = paused_;
  s.refining = finishing_update_ || (!paused_ && graph_.refining());
  return s;
}

void BackendWorker::publishStatus() {
  output_->publishStatus(status());
  last_status_publish_ = now();
}

// ---------------------------------------------------------------- commands

CommandResult BackendWorker::saveGraph(const std::string& filename) {
  return call([this, filename]() -> CommandResult {
    if (filename.empty()) return {false, "empty filename"};
    if (graph_.numNodes() == 0) return {false, "the graph is empty"};
    try {
      ros_backend::saveGraph(graph_.save(), filename);
    } catch (const std::exception& e) {
      return {false, e.what()};
    }
    return {true, "saved " + std::to_string(graph_.numNodes()) + " nodes and " +
                      std::to_string(graph_.numLoopClosures()) + " loop closures to " + filename + " (+ " +
                      sidecarPath(filename) + ")"};
  });
}

CommandResult BackendWorker::loadGraph(const std::string& filename) {
  return call([this, filename]() -> CommandResult {
    if (filename.empty()) return {false, "empty filename"};
    try {
      const int t = parameters_.dimension == 2 ? 3 : 6;
      const Eigen::MatrixXd prior =
          Eigen::MatrixXd::Identity(t, t) / (parameters_.prior_sigma * parameters_.prior_sigma);
      const SavedGraph saved = ros_backend::loadGraph(filename, prior);
      graph_.load(saved);
      pending_latency_.clear();
      needs_update_ = !saved.has_state;
      if (needs_update_ && !paused_) solve();
    } catch (const std::exception& e) {
      return {false, std::string("load failed, graph unchanged: ") + e.what()};
    }
    return {true, "loaded " + std::to_string(graph_.numNodes()) + " nodes and " +
                      std::to_string(graph_.numLoopClosures()) + " loop closures from " + filename};
  });
}

CommandResult BackendWorker::saveTrajectory(const std::string& filename) {
  return call([this, filename]() -> CommandResult {
    if (filename.empty()) return {false, "empty filename"};
    if (graph_.numNodes() == 0) return {false, "the graph is empty"};
    std::vector<double> stamps;
    for (const ros::Time& t : graph_.stamps()) stamps.push_back(t.toSec());
    core::writeTumTrajectory(graph_.engine()->poses(), filename, stamps);
    return {true, "wrote " + std::to_string(stamps.size()) + " poses to " + filename};
  });
}

CommandResult BackendWorker::optimize() {
  return call([this]() -> CommandResult {
    if (graph_.numNodes() == 0) return {false, "the graph is empty"};
    core::UpdateStats stats;
    std::string error;
    needs_update_ = false;
    pending_latency_.clear();
    if (!graph_.optimize(&stats, &error)) {
      std::lock_guard<std::mutex> lock(counters_mutex_);
      ++counters_.failed_updates;
      return {false, error};
    }
    last_update_ = ros::Time::now();
    if (stats.converged)
      return {true, "optimised: converged after " + std::to_string(stats.iterations) + " iterations"};
    return {true, "optimised: stopped at the iteration cap (~optimize_iterations = " +
                      std::to_string(parameters_.optimize_iterations) + ") after " +
                      std::to_string(stats.iterations) + " iterations, not converged"};
  });
}

CommandResult BackendWorker::reset() {
  return call([this]() -> CommandResult {
    graph_.reset();
    needs_update_ = false;
    pending_latency_.clear();
    latencies_ms_.clear();
    first_latencies_ms_.clear();
    {
      std::lock_guard<std::mutex> lock(counters_mutex_);
      counters_ = Counters();
    }
    return {true, "graph cleared"};
  });
}

CommandResult BackendWorker::setPaused(bool paused) {
  return call([this, paused]() -> CommandResult {
    paused_ = paused;
    parameters_.paused = paused;
    if (!paused_ && needs_update_) solve();
    return {true, paused ? "paused: messages are added, no solves" : "resumed"};
  });
}

void BackendWorker::reconfigure(const BackendParameters& next) {
  post([this, next]() -> CommandResult {
    BackendParameters in_force = parameters_;
    in_force.paused = paused_;
    const std::string changes = describeChanges(in_force, next);
    if (changes.empty()) return {true, "no change"};
    const double start = now();
    bool rebuilt = false;
    try {
      rebuilt = graph_.setParameters(next);
    } catch (const std::exception& e) {
      const std::string message = "runtime parameters not applied (" + changes + "): " + e.what();
      ROS_WARN_STREAM("agnc_pgo: " << message);
      return {false, message};
    }
    parameters_ = next;
    std::ostringstream message;
    message << "runtime parameters applied: " << changes;
    if (rebuilt)
      message << " (engine rebuilt from its state: " << graph_.numNodes() << " nodes, " << graph_.numLoopClosures()
              << " loop closures, " << static_cast<int>((now() - start) * 1e3 + 0.5) << " ms)";
    ROS_INFO_STREAM("agnc_pgo: " << message.str());
    if (paused_ != next.paused) {
      paused_ = next.paused;
      if (!paused_ && needs_update_) solve();
    }
    return {true, message.str()};
  });
}

CommandResult BackendWorker::setLoopClosureStatus(int index, core::LoopOverride mode) {
  return call([this, index, mode]() -> CommandResult { return applyOverride(index, mode); });
}

CommandResult BackendWorker::setLoopClosureStatus(const ros::Time& from_stamp, const ros::Time& to_stamp,
                                                  core::LoopOverride mode) {
  return call([this, from_stamp, to_stamp, mode]() -> CommandResult {
    const int index = graph_.findLoopClosure(from_stamp, to_stamp);
    if (index < 0)
      return {false, "no loop closure between the keyframes at " + std::to_string(from_stamp.toSec()) + " and " +
                         std::to_string(to_stamp.toSec())};
    return applyOverride(index, mode);
  });
}

CommandResult BackendWorker::applyOverride(int index, core::LoopOverride mode) {
  if (index < 0 || index >= graph_.numLoopClosures())
    return {false, "unknown loop closure " + std::to_string(index) + " (graph has " +
                       std::to_string(graph_.numLoopClosures()) + ")"};
  const int regraduating = graph_.setOverride(index, mode);
  needs_update_ = true;
  if (!paused_) solve();
  const core::LoopClosure& loop = graph_.engine()->loopClosures()[index];
  std::string message =
      "loop closure " + std::to_string(index) + " is now " + (loop.inlier ? "an inlier" : "an outlier");
  if (regraduating > 0)
    message += "; " + std::to_string(regraduating) + " loop closures whose classification the override had "
               "changed graduated again";
  return {true, message};
}

}  // namespace ros_backend
}  // namespace agnc_pgo
