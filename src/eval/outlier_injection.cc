// False loop closures as in riSAM's experiments (ALGORITHM.md §5).
#include "agnc_pgo/eval/outlier_injection.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <random>
#include <set>
#include <stdexcept>
#include <utility>

#include "agnc_pgo/core/chi_square.h"

namespace agnc_pgo {
namespace core {

namespace {

std::string toLower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

bool contains(const std::string& haystack, const char* needle) {
  return haystack.find(needle) != std::string::npos;
}

Eigen::VectorXd vector3(double a, double b, double c) { return Eigen::Vector3d(a, b, c); }

Eigen::VectorXd vector6(double a, double b, double c, double d, double e, double f) {
  Eigen::VectorXd v(6);
  v << a, b, c, d, e, f;
  return v;
}

// True loop closures only: outliers already present must not inflate L.
int countTrueLoops(const PoseGraph& graph) {
  return static_cast<int>(std::count_if(graph.edges.begin(), graph.edges.end(), [](const Edge& edge) {
    return edge.kind == EdgeKind::kLoopClosure && !edge.is_outlier;
  }));
}

Eigen::VectorXd outlierCovariance(const PoseGraph& graph, const std::string& dataset_name,
                                  const OutlierOptions& options) {
  if (options.covariance_diagonal.size() == 0) {
    return defaultOutlierCovariance(dataset_name, graph.dimension);
  }
  const Eigen::VectorXd& covariance = options.covariance_diagonal;
  if (covariance.size() != graph.tangentDimension()) {
    throw std::invalid_argument("injectOutliers: covariance diagonal has " + std::to_string(covariance.size()) +
                                " entries, expected " + std::to_string(graph.tangentDimension()));
  }
  // `!(x > 0)` also rejects NaN.
  if (!(covariance.array() > 0.0).all() || !covariance.allFinite()) {
    throw std::invalid_argument("injectOutliers: covariance diagonal must be positive and finite");
  }
  return covariance;
}

// Number of pairs (i, j) with 0 <= j, i < N and i - j >= 2.
long long candidatePairCount(int num_poses) {
  const long long n = num_poses;
  return n < 3 ? 0 : (n - 1) * (n - 2) / 2;
}

}  // namespace

Eigen::VectorXd defaultOutlierCovariance(const std::string& dataset_name, int dimension) {
  const std::string name = toLower(dataset_name);
  if (dimension == 2) {
    if (contains(name, "intel")) return vector3(0.0024, 0.0024, 0.0002);
    if (contains(name, "manhattan")) return vector3(0.0224, 0.0224, 0.0224);
    return vector3(0.015, 0.01, 0.001);  // csail, and the SE(2) fallback
  }
  if (dimension == 3) {
    // Sphere2500 (the only SE(3) dataset) in our g2o order: x y z rx ry rz.
    return vector6(0.1, 0.1, 0.1, 0.0025, 0.0025, 0.0025);
  }
  throw std::invalid_argument("defaultOutlierCovariance: dimension must be 2 or 3, got " +
                              std::to_string(dimension));
}

int numOutliersFor(int true_loops, double percent) {
  if (!(percent >= 0.0 && percent < 100.0)) {  // also rejects NaN
    throw std::invalid_argument("numOutliersFor: percent must be in [0, 100), got " + std::to_string(percent));
  }
  if (true_loops < 0) throw std::invalid_argument("numOutliersFor: negative loop count");
  const double exact = percent * static_cast<double>(true_loops) / (100.0 - percent);
  // A quotient that is mathematically an integer can land just below it in
  // floating point (33.6 * 249 / 66.4 = 125.99999999999999 instead of 126);
  // a small relative tolerance keeps floor() from losing one outlier.
  const double tolerance = 1e-9 * std::max(1.0, exact);
  return static_cast<int>(std::floor(exact + tolerance));
}

PoseGraph injectOutliers(const PoseGraph& graph, const PoseGraph& reference, const std::string& dataset_name,
                         const OutlierOptions& options) {
  if (graph.dimension != 2 && graph.dimension != 3) {
    throw std::invalid_argument("injectOutliers: dimension must be 2 or 3");
  }
  if (reference.poses.size() != graph.poses.size()) {
    throw std::invalid_argument("injectOutliers: reference has " + std::to_string(reference.poses.size()) +
                                " poses, graph " + std::to_string(graph.poses.size()));
  }
  const int num_outliers = numOutliersFor(countTrueLoops(graph), options.percent);
  PoseGraph result = graph;
  if (num_outliers == 0) return result;

  const int num_poses = static_cast<int>(graph.poses.size());
  if (num_poses < 3) {
    throw std::invalid_argument("injectOutliers: need at least 3 poses to place outliers");
  }
  const long long total_pairs = candidatePairCount(num_poses);
  if (num_outliers > total_pairs) {
    throw std::invalid_argument("injectOutliers: " + std::to_string(num_outliers) +
                                " outliers requested but only " + std::to_string(total_pairs) + " pose pairs");
  }

  const Eigen::VectorXd covariance = outlierCovariance(graph, dataset_name, options);
  const Eigen::MatrixXd information = covariance.cwiseInverse().asDiagonal();
  const int dof = graph.tangentDimension();
  const double threshold = chiSquareQuantile(dof, 0.95);

  std::mt19937_64 rng(options.seed);
  std::uniform_int_distribution<int> draw_pose(0, num_poses - 1);
  // Every pair decided so far, accepted or rejected. A rejected pair would be
  // rejected again, so skipping it does not change which pairs are chosen;
  // it only makes "every pair tried" detectable instead of looping forever.
  std::set<std::pair<int, int>> decided;
  int added = 0;
  while (added < num_outliers) {
    const int i = draw_pose(rng);
    const int j = draw_pose(rng);
    if (i - j < 2) continue;  // enforces i > j and |i - j| >= 2
    if (!decided.insert({i, j}).second) {
      if (static_cast<long long>(decided.size()) == total_pairs) {
        throw std::runtime_error("injectOutliers: only " + std::to_string(added) + " of " +
                                 std::to_string(num_outliers) + " outliers are inconsistent with the reference");
      }
      continue;
    }
    // An identity measurement that the true relative pose explains within the
    // 95 % gate would be a true loop, not an outlier. The gate compares the
    // Mahalanobis distance r (not r^2) with the quantile, as the reference
    // implementations' tests do (ALGORITHM.md §1, §3), so that every injected
    // outlier is an outlier under the engine's default classification too.
    const Eigen::VectorXd error =
        relativePoseError(graph.dimension, reference.poses[i], reference.poses[j], Pose::identity());
    if (std::sqrt(error.dot(information * error)) < threshold) continue;

    Edge edge;
    edge.from = i;
    edge.to = j;
    edge.measurement = Pose::identity();
    edge.information = information;
    edge.kind = EdgeKind::kLoopClosure;
    edge.is_outlier = true;
    result.edges.push_back(edge);
    ++added;
  }
  return result;
}

}  // namespace core
}  // namespace agnc_pgo
