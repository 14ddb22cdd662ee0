#include "agnc_pgo/core/batch_solver.h"

#include <chrono>
#include <limits>
#include <memory>
#include <stdexcept>
#include <vector>

#include <ceres/ceres.h>

#include "agnc_pgo/core/global_initialization.h"
#include "agnc_pgo/core/pose_manifolds.h"
#include "cholmod_threads.h"

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
  keepCholmodSerial();  // Ceres factorises with CHOLMOD
  ceres::Solve(solver_options, &problem, &summary);

  for (size_t i = 0; i < blocks.size(); ++i) graph->poses[i] = fromBlock(dim, blocks[i]);
  BatchResult result;
  result.initial_cost = summary.initial_cost;
  result.final_cost = summary.final_cost;
  result.iterations = static_cast<int>(summary.iterations.size());
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  return result;
}

std::string toString(BatchStart start) {
  switch (start) {
    case BatchStart::kOdometry: return "odometry";
    case BatchStart::kGlobalInitialization: return "global";
    case BatchStart::kGroundTruth: return "ground_truth";
  }
  return "unknown";
}

const BatchStartResult& GlobalBatchResult::bestStart() const {
  for (const BatchStartResult& s : starts)
    if (s.start == best) return s;
  throw std::logic_error("GlobalBatchResult: no result for the best start");
}

namespace {

using PoseVector = std::vector<Pose, Eigen::aligned_allocator<Pose>>;

double seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

// The ground truth moved rigidly so that the graph's gauge pose keeps its
// value: Levenberg-Marquardt holds that pose constant.
PoseVector groundTruthOnGauge(const PoseGraph& graph, const PoseVector& ground_truth) {
  if (ground_truth.size() != graph.poses.size())
    throw std::invalid_argument("optimizeBatchGlobal: the ground truth has " + std::to_string(ground_truth.size()) +
                                " poses, the graph " + std::to_string(graph.poses.size()));
  const int gauge = graph.fixed.empty() ? 0 : graph.fixed.front();
  const Pose offset = graph.poses[gauge] * ground_truth[gauge].inverse();
  PoseVector moved(ground_truth.size());
  for (size_t i = 0; i < ground_truth.size(); ++i) moved[i] = offset * ground_truth[i];
  for (int id : graph.fixed) moved[id] = graph.poses[id];
  return moved;
}

}  // namespace

GlobalBatchResult optimizeBatchGlobal(PoseGraph* graph, const BatchOptions& options,
                                      const PoseVector* ground_truth) {
  GlobalBatchResult result;
  if (graph->poses.empty()) return result;
  PoseVector best_poses;
  auto run = [&](BatchStart start, const PoseVector& initial, double initialization_s) {
    PoseGraph copy = *graph;
    copy.poses = initial;
    BatchStartResult r;
    r.start = start;
    r.initialization_s = initialization_s;
    r.batch = optimizeBatch(&copy, options);
    r.chi2 = 2.0 * r.batch.final_cost;
    if (result.starts.empty() || r.chi2 < result.chi2 * (1.0 - 1e-9)) {
      result.best = start;
      result.chi2 = r.chi2;
      best_poses = copy.poses;
    }
    result.starts.push_back(r);
  };

  run(BatchStart::kOdometry, graph->poses, 0.0);
  const auto started = std::chrono::steady_clock::now();
  GlobalInitializationOptions init_options;
  init_options.skip_outliers = options.skip_outliers;
  try {
    const PoseVector global = globalInitialization(*graph, init_options);
    run(BatchStart::kGlobalInitialization, global, seconds(started));
  } catch (const std::exception& e) {
    BatchStartResult failed;
    failed.start = BatchStart::kGlobalInitialization;
    failed.chi2 = std::numeric_limits<double>::quiet_NaN();
    failed.error = e.what();
    result.starts.push_back(failed);
  }
  if (ground_truth) run(BatchStart::kGroundTruth, groundTruthOnGauge(*graph, *ground_truth), 0.0);
  graph->poses = best_poses;
  return result;
}

}  // namespace core
}  // namespace agnc_pgo
