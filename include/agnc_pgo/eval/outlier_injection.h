// False loop closures as in riSAM's experiments (ALGORITHM.md §5).
#pragma once

#include <cstdint>
#include <string>

#include "agnc_pgo/core/pose_graph.h"

namespace agnc_pgo {
namespace core {

struct OutlierOptions {
  double percent = 10.0;   // share of all loop closures that are false, [0, 100)
  std::uint64_t seed = 1;  // the run is reproducible for a given seed
  // Diagonal covariance of an outlier (g2o order: x y theta / x y z rx ry rz).
  // Empty = defaultOutlierCovariance(dataset name, dimension).
  Eigen::VectorXd covariance_diagonal;
};

// riSAM's per-dataset outlier noise (shared/irl/README.md), matched on the
// dataset name (csail, intel, manhattan, sphere; case-insensitive). Unknown
// names get CSAIL's (SE(2)) or Sphere2500's (SE(3)) values.
Eigen::VectorXd defaultOutlierCovariance(const std::string& dataset_name, int dimension);

// Number of outliers for L true loop closures: floor(p * L / (100 - p)).
int numOutliersFor(int true_loops, double percent);

// Returns a copy of `graph` with outlier loop closures appended (is_outlier =
// true): each joins random poses i > j, |i - j| >= 2, measurement = identity,
// diagonal covariance (options or the dataset's default), and pairs whose true relative pose (from `reference`, the
// outlier-free optimum or ground truth) has a Mahalanobis distance r (not
// r^2) below chi2 q(0.95) from the
// identity under that noise are rejected and redrawn. Deterministic per seed
// (std::mt19937_64).
PoseGraph injectOutliers(const PoseGraph& graph, const PoseGraph& reference,
                         const std::string& dataset_name, const OutlierOptions& options);

}  // namespace core
}  // namespace agnc_pgo
