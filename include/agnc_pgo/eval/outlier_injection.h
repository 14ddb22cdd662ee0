// False loop closures as in riSAM's experiments (ALGORITHM.md §5).
#pragma once

#include <cstdint>
#include <string>

#include "agnc_pgo/core/pose_graph.h"

namespace agnc_pgo {
namespace core {

// How outliers are placed, after the four modes of Vertigo's generator
// (Suenderhauf's datasets/generateDataset.py), which imitate how real
// front-ends fail: a false match anywhere (random), a false match with a
// recent place (local), and a perceptually aliased stretch that yields a run
// of consecutive false matches with one wrong measurement (grouped).
enum class OutlierMode {
  // riSAM's protocol (ALGORITHM.md §5): random poses i > j, |i - j| >= 2,
  // identity measurement.
  kRandom,
  // As kRandom, but the older endpoint lies local_min_separation ..
  // local_max_separation poses before the newer one.
  kLocal,
  // Groups of group_size consecutive pose pairs (i + k, j + k), k = 0 ..
  // group_size - 1, sharing ONE random wrong measurement; i - j >= 2.
  kRandomGrouped,
  // As kRandomGrouped with i - j in [local_min_separation, local_max_separation].
  kLocalGrouped,
};

// "random", "local", "random-grouped", "local-grouped".
std::string toString(OutlierMode mode);
// Inverse of toString; throws std::invalid_argument naming the valid modes.
OutlierMode parseOutlierMode(const std::string& text);
bool isGrouped(OutlierMode mode);
bool isLocal(OutlierMode mode);

// The separation range of the local modes: a front-end that matches a
// recently seen place falsely does so a few tens of keyframes back (the issue
// asks for 20-50 poses; Vertigo's generator used up to 20). Close enough to
// the robot that the map around both endpoints is still uncertain, far
// enough that odometry alone does not contradict the match.
constexpr int kDefaultLocalMinSeparation = 20;
constexpr int kDefaultLocalMaxSeparation = 50;
// Vertigo's default group size for its grouped experiments.
constexpr int kDefaultGroupSize = 10;

struct OutlierOptions {
  double percent = 10.0;   // share of all loop closures that are false, [0, 100)
  std::uint64_t seed = 1;  // the run is reproducible for a given seed
  OutlierMode mode = OutlierMode::kRandom;
  // Grouped modes: pose pairs per group (>= 1). The last group is shorter
  // when n_out is not a multiple of it.
  int group_size = kDefaultGroupSize;
  // Local modes: i - j in [local_min_separation, local_max_separation],
  // 2 <= min <= max.
  int local_min_separation = kDefaultLocalMinSeparation;
  int local_max_separation = kDefaultLocalMaxSeparation;
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

// Throws std::invalid_argument naming the first invalid field.
void validate(const OutlierOptions& options);

// Returns a copy of `graph` with n_out = numOutliersFor(L, percent) outlier
// loop closures appended (is_outlier = true, edge from = the newer pose i, to
// = the older pose j), each with the diagonal covariance of the options or the
// dataset's default.
//
// kRandom / kLocal: each joins poses i > j (|i - j| >= 2, or in the local
// range), measurement = identity; pairs whose true relative pose (from
// `reference`, the outlier-free optimum or ground truth) has a Mahalanobis
// distance r (not r^2) below chi2 q(0.95) from the identity under that noise
// are rejected and redrawn.
//
// kRandomGrouped / kLocalGrouped: groups of group_size pairs (i + k, j + k)
// sharing one measurement z, until n_out outliers are placed (the last group
// may be shorter). z is a random relative pose of the size a true loop
// closure of the dataset has: translation uniform in the disc (SE(2)) or ball
// (SE(3)) whose radius is the median translation of the graph's true
// loop-closure measurements (1 m if that is 0), heading uniform in [-pi, pi)
// (SE(2)) or rotation uniform on SO(3) (SE(3)) -- a false match may come at
// any heading. Every member is gated against the reference like a random
// outlier; if one member is consistent with z (the truth explains it), or
// reuses a pose pair already used, the whole group is redrawn (new start, new
// z), so that every group is a run of consecutive pairs.
//
// Deterministic per seed (std::mt19937_64); kRandom draws exactly as before
// the other modes existed. Throws std::invalid_argument for invalid options
// or a graph too small for the mode, std::runtime_error if no placement
// passes the gate.
PoseGraph injectOutliers(const PoseGraph& graph, const PoseGraph& reference,
                         const std::string& dataset_name, const OutlierOptions& options);

// injectOutliers gated against the outlier-free optimum of `graph` itself:
// the geometry the data supports (a ground truth can differ from it by
// metres -- ring, M3500, Sphere2500 -- and let through "outliers" the data
// cannot tell from true loop closures). Started globally
// (optimizeBatchGlobal): from the odometry alone least squares can end in a
// local minimum (M3500b). What agnc_pgo_replay and the dataset player inject,
// so both give the same loop closures for the same options.
PoseGraph injectOutliersAgainstOptimum(const PoseGraph& graph, const std::string& dataset_name,
                                       const OutlierOptions& options);

}  // namespace core
}  // namespace agnc_pgo
