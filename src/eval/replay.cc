#include "agnc_pgo/eval/replay.h"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <string>

#include "agnc_pgo/core/incremental_gnc.h"

namespace agnc_pgo {
namespace core {

namespace {

// Feeds one log entry to the engine (without updating it).
void addEntry(const LogEntry& entry, IncrementalGnc* engine) {
  switch (entry.type) {
    case EntryType::kPrior:
      // Pose 0, or the first pose of a later odometry chain.
      if (entry.edge.to != engine->numPoses())
        throw std::invalid_argument("a prior must start a new pose (pose " + std::to_string(entry.edge.to) +
                                    " of a graph with " + std::to_string(engine->numPoses()) + ")");
      engine->addPoseWithPrior(entry.edge.measurement, entry.edge.information);
      break;
    case EntryType::kOdometry:
      if (engine->numPoses() == 0) throw std::invalid_argument("odometry before the prior");
      engine->addOdometry(entry.edge);
      break;
    case EntryType::kLoopClosure:
      engine->addLoopClosure(entry.edge);
      break;
  }
}

// A loop closure's update: its latency, that of its first estimate, and
// what the engine did.
void recordLoopUpdate(double seconds, double first_estimate_s, int poses, const UpdateStats& stats,
                      ReplayResult* result) {
  auto& histogram = result->solves_per_update_histogram;
  if (static_cast<int>(histogram.size()) <= stats.iterations) histogram.resize(stats.iterations + 1, 0);
  ++histogram[stats.iterations];
  result->loop_update_ms.push_back(seconds * 1e3);
  result->first_estimate_ms.push_back(first_estimate_s * 1e3);
  result->loop_update_poses.push_back(poses);
  result->loop_update_stats.push_back(stats);
}

// The final estimate, each loop closure's state and the precision / recall
// counts against the log's labels.
void collectFinalState(IncrementalGnc* engine, ReplayResult* result) {
  engine->classifyAll();
  result->estimate = engine->poses();
  result->solves = engine->totalIterations();
  result->gnc_steps = engine->totalGncSteps();
  result->noise_scale = engine->noiseScale();
  std::vector<bool> labels, kept;
  for (const LoopClosure& loop : engine->loopClosures()) {
    LoopClosureResult r;
    r.edge = loop.edge;
    r.mu = loop.graduation.mu;
    r.weight = loop.weight;
    r.distance = loop.distance;
    r.inlier = loop.inlier;
    r.uncorroborated = loop.uncorroborated;
    result->loop_closures.push_back(r);
    labels.push_back(loop.edge.is_outlier);
    kept.push_back(loop.inlier);
  }
  result->counts = classify(labels, kept);
}

}  // namespace

ReplayResult replay(const IncrementalLog& log, const ReplayOptions& options) {
  using Clock = std::chrono::steady_clock;
  ReplayResult result;
  IncrementalGnc engine(log.dimension, options.gnc);
  const size_t total = log.entries.size();
  double free_pose_solves = 0.0;
  for (size_t k = 0; k < total; ++k) {
    const LogEntry& entry = log.entries[k];
    const auto start = Clock::now();
    addEntry(entry, &engine);
    // The anytime first estimate (IncrementalGnc::update()): when a caller
    // could publish the estimate; the whole update if there is none.
    double first_estimate_s = -1.0;
    const UpdateStats stats = engine.update(
        [&] { first_estimate_s = std::chrono::duration<double>(Clock::now() - start).count(); });
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    if (first_estimate_s < 0.0) first_estimate_s = seconds;
    result.runtime_s += seconds;
    if (entry.type == EntryType::kLoopClosure)
      recordLoopUpdate(seconds, first_estimate_s, engine.numPoses(), stats, &result);
    free_pose_solves += static_cast<double>(stats.iterations) * (engine.numPoses() - stats.first_variable);
    if (options.progress) options.progress(k + 1, total);
  }
  const auto idle_start = Clock::now();
  while (engine.refineIdle()) ++result.idle_refinement_iterations;
  const double idle_s = std::chrono::duration<double>(Clock::now() - idle_start).count();
  result.idle_refinement_ms = idle_s * 1e3;
  result.runtime_s += idle_s;
  collectFinalState(&engine, &result);
  if (result.solves > 0) result.mean_free_poses = free_pose_solves / result.solves;
  return result;
}

PoseGraph resultGraph(const IncrementalLog& log, const ReplayResult& result) {
  PoseGraph graph;
  graph.dimension = log.dimension;
  graph.file_ids = log.file_ids;
  graph.poses = result.estimate;
  for (const LogEntry& entry : log.entries)
    if (entry.type != EntryType::kPrior) graph.edges.push_back(entry.edge);
  graph.fixed = {0};
  return graph;
}

}  // namespace core
}  // namespace agnc_pgo
