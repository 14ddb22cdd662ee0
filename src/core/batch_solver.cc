#include "agnc_pgo/core/batch_solver.h"

#include <memory>
#include <vector>

#include <ceres/ceres.h>

#include "agnc_pgo/core/pose_manifolds.h"

namespace agnc_pgo {
namespace core {

BatchResult optimizeBatch(PoseGraph* graph, const BatchOptions& options) {
  const int dim = graph->dimension;
  std::vector<PoseBlock> blocks;
  blocks.reserve(graph->poses.size());
  for (const Pose& p : graph->poses) blocks.push_back(toBlock(dim, p));

  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  const std::unique_ptr<ceres::Manifold> manifold = makePoseManifold(dim);
  const int ambient = dim == 2 ? 3 : 7;
  for (PoseBlock& b : blocks) problem.AddParameterBlock(b.data(), ambient, manifold.get());
  for (const Edge& e : graph->edges) {
    if (options.skip_outliers && e.is_outlier) continue;
    problem.AddResidualBlock(makePoseErrorCost(dim, e.measurement, e.information), nullptr,
                             blocks[e.from].data(), blocks[e.to].data());
  }
  if (graph->fixed.empty()) {
    if (!blocks.empty()) problem.SetParameterBlockConstant(blocks[0].data());
  } else {
    for (int id : graph->fixed) problem.SetParameterBlockConstant(blocks[id].data());
  }

  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.gradient_tolerance = 1e-12;
  solver_options.parameter_tolerance = 1e-12;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);

  for (size_t i = 0; i < blocks.size(); ++i) graph->poses[i] = fromBlock(dim, blocks[i]);
  BatchResult result;
  result.initial_cost = summary.initial_cost;
  result.final_cost = summary.final_cost;
  result.iterations = static_cast<int>(summary.iterations.size());
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  return result;
}

}  // namespace core
}  // namespace agnc_pgo
