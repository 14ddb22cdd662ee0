// Replays an incremental log through the engine entry by entry, as a
// front-end would feed it (ALGORITHM.md §5): the estimate is brought up to
// date after every entry, and every update is timed.
#pragma once

#include <functional>
#include <vector>

#include "agnc_pgo/core/gnc_options.h"
#include "agnc_pgo/core/incremental_gnc.h"
#include "agnc_pgo/eval/incremental_log.h"
#include "agnc_pgo/core/statistics.h"  // percentile, used with replay results
#include "agnc_pgo/eval/metrics.h"

namespace agnc_pgo {
namespace core {

struct ReplayOptions {
  GncOptions gnc;
  // Called after every entry with (entries done, entries total).
  std::function<void(size_t, size_t)> progress;
};

struct LoopClosureResult {
  Edge edge;             // as delivered (is_outlier = ground-truth label)
  double mu = 0;         // final mu
  double weight = 0;     // final kernel weight
  double distance = 0;   // final whitened residual norm r
  bool inlier = false;   // final classification
  bool uncorroborated = false;  // LoopClosure::uncorroborated
};

struct ReplayResult {
  Poses estimate;
  std::vector<LoopClosureResult> loop_closures;
  double runtime_s = 0;         // total wall time of all updates and of the idle refinement
  // At the end of the log, what the node does once messages stop
  // (IncrementalGnc::refineIdle() until it has nothing left to do).
  double idle_refinement_ms = 0;
  int idle_refinement_iterations = 0;
  long solves = 0;              // Gauss-Newton iterations over the run
  long gnc_steps = 0;
  Eigen::VectorXd noise_scale;  // IncrementalGnc::noiseScale() at the end (translation first)
  double mean_free_poses = 0;   // average number of free poses per solve
  std::vector<int> solves_per_update_histogram;  // [k] = updates that took k solves
  std::vector<double> loop_update_ms;    // one per update that had loop closures
  // ... and the time to its first estimate (IncrementalGnc::update()'s
  // anytime callback; the whole update where nothing was left after it).
  std::vector<double> first_estimate_ms;
  std::vector<int> loop_update_poses;    // graph size at each of those updates
  std::vector<UpdateStats> loop_update_stats;  // what each of those updates did
  ClassificationCounts counts;
};

// Throws std::invalid_argument if the log is not a valid sequence (no prior
// first, an entry referring to an unknown pose).
ReplayResult replay(const IncrementalLog& log, const ReplayOptions& options);

// The estimate as a graph (poses + every odometry and loop-closure edge).
PoseGraph resultGraph(const IncrementalLog& log, const ReplayResult& result);

}  // namespace core
}  // namespace agnc_pgo
