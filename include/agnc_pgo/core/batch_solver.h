// Batch least-squares optimisation of a whole pose graph with ceres::Solve
// (Levenberg-Marquardt, SPARSE_NORMAL_CHOLESKY). Used for references (the
// outlier-free optimum) and to cross-check the incremental engine; it has no
// robust kernel.
#pragma once

#include <string>
#include <vector>

#include "agnc_pgo/core/pose_graph.h"

namespace agnc_pgo {
namespace core {

struct BatchOptions {
  int max_iterations = 100;
  bool skip_outliers = false;  // leave out edges labelled is_outlier
  double function_tolerance = 1e-12;
};

struct BatchResult {
  double initial_cost = 0;  // Ceres cost: 0.5 * sum |S e|^2
  double final_cost = 0;
  int iterations = 0;
  bool converged = false;
};

// Optimises graph->poses in place. Gauge: the FIX ids, or pose 0.
BatchResult optimizeBatch(PoseGraph* graph, const BatchOptions& options = BatchOptions());

// Where a Levenberg-Marquardt run of optimizeBatchGlobal starts.
enum class BatchStart {
  kOdometry,              // the graph's own poses (odometry composition for edges-only files)
  kGlobalInitialization,  // globalInitialization() (LAGO in 2D, chordal rotations in 3D)
  kGroundTruth,           // the ground truth, moved rigidly onto the graph's gauge pose
};
std::string toString(BatchStart start);  // "odometry", "global", "ground_truth"

struct BatchStartResult {
  BatchStart start = BatchStart::kOdometry;
  double chi2 = 0;                 // 2 * final Ceres cost = sum r^T I r; NaN if the start failed
  double initialization_s = 0;     // time to compute the start (0 for the odometry)
  BatchResult batch;
  std::string error;               // why the start could not be computed; empty if it ran
};

struct GlobalBatchResult {
  BatchStart best = BatchStart::kOdometry;
  double chi2 = 0;                        // of the best start
  std::vector<BatchStartResult> starts;   // every start, in the order of BatchStart
  const BatchStartResult& bestStart() const;
};

// optimizeBatch from every start (the ground truth only when given, one pose
// per id) and keeps the lowest final cost in graph->poses. Least squares from
// the odometry alone can end in a local minimum when the odometry has drifted
// far (tens of degrees); the global initialisation does not depend on it.
// Near-ties (relative 1e-9) go to the earlier start, so an unambiguous
// optimum is reported as reached from the odometry. A global initialisation
// that cannot be computed (a pose not connected to the gauge) leaves its
// start with an error and the others decide.
GlobalBatchResult optimizeBatchGlobal(PoseGraph* graph, const BatchOptions& options = BatchOptions(),
                                      const std::vector<Pose, Eigen::aligned_allocator<Pose>>* ground_truth =
                                          nullptr);

}  // namespace core
}  // namespace agnc_pgo
