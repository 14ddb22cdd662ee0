// Batch least-squares optimisation of a whole pose graph with ceres::Solve
// (Levenberg-Marquardt, SPARSE_NORMAL_CHOLESKY). Used for references (the
// outlier-free optimum) and to cross-check the incremental engine; it has no
// robust kernel.
#pragma once

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

}  // namespace core
}  // namespace agnc_pgo
