// Helpers shared by the files of IncrementalGnc (incremental_gnc.cc and its
// idle checks); not part of the library's interface.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

#include "agnc_pgo/core/pose_graph.h"
#include "agnc_pgo/core/sparse_pose_graph_solver.h"

namespace agnc_pgo {
namespace core {
namespace internal {

// The next Gauss-Newton step over this one per unit of |1 - rho| when the
// model's error is cubic (convergenceStep).
constexpr double kCubicNextStep = 1.5;

// The step that decides convergence is the one the next iteration would
// take, estimated from this one. A step the trust region cut short says
// nothing about it. A full Gauss-Newton step leaves two things for the
// next: what the linear solve left of the model's gradient (the relative
// residual of H delta = -g; 0 after a factorisation) and the model's own
// error, measured by the ratio rho of the actual to the predicted decrease.
// For a cubic error the next step is 3/2 |1 - rho| times this one (in 1-D,
// f = the quadratic model + t x^3 / 6: 1 - rho = t delta / (3 f''), the
// next gradient t delta^2 / 2, so the next step is t delta^2 / (2 f'')).
// Where the model is accurate the iterations stop after the step instead
// of taking another just to see it small; where it is poor, or the solve
// was loose, the step itself counts as before.
inline double convergenceStep(const IterationResult& r) {
  if (r.truncated) return std::numeric_limits<double>::infinity();
  if (!SparsePoseGraphSolver::meaningfulDecrease(r.predicted_decrease, r.cost_before)) return r.mean_step;
  const double rho = (r.cost_before - r.cost_after) / r.predicted_decrease;
  return r.mean_step * std::min(1.0, kCubicNextStep * std::abs(1.0 - rho) + r.solve_residual);
}

inline int olderEnd(const Edge& e) { return std::min(e.from, e.to); }
inline int newerEnd(const Edge& e) { return std::max(e.from, e.to); }

}  // namespace internal
}  // namespace core
}  // namespace agnc_pgo
