// False loop closures as in riSAM's experiments (ALGORITHM.md §5).
#include "agnc_pgo/eval/outlier_injection.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <random>
#include <set>
#include <stdexcept>
#include <utility>
#include <vector>

#include "agnc_pgo/core/batch_solver.h"
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

// Number of pairs (i, j) with 0 <= j, i < N and min <= i - j <= max.
long long localPairCount(int num_poses, int min_separation, int max_separation) {
  long long count = 0;
  for (int d = min_separation; d <= max_separation && d < num_poses; ++d) count += num_poses - d;
  return count;
}

// Consecutive rejected groups after which the grouped modes give up.
constexpr int kMaxFailedGroupDraws = 100000;

// Radius of the shared wrong measurement's translation: the median length of
// the graph's true loop-closure measurements (1 m when that is 0).
double typicalLoopLength(const PoseGraph& graph) {
  std::vector<double> lengths;
  for (const Edge& edge : graph.edges) {
    if (edge.kind == EdgeKind::kLoopClosure && !edge.is_outlier) lengths.push_back(edge.measurement.translation.norm());
  }
  if (lengths.empty()) return 1.0;
  std::sort(lengths.begin(), lengths.end());
  const std::size_t n = lengths.size();
  const double median = n % 2 ? lengths[n / 2] : 0.5 * (lengths[n / 2 - 1] + lengths[n / 2]);
  return median > 0.0 ? median : 1.0;
}

// A random relative pose of a false match: translation uniform in the disc
// (SE(2)) or ball (SE(3)) of `radius`, heading uniform in [-pi, pi) or
// rotation uniform on SO(3) (a normalised 4-D Gaussian quaternion).
Pose randomMeasurement(int dimension, double radius, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  if (dimension == 2) {
    const double r = radius * std::sqrt(unit(rng));
    const double direction = 2.0 * M_PI * unit(rng);
    const double yaw = -M_PI + 2.0 * M_PI * unit(rng);
    return Pose::fromSE2(r * std::cos(direction), r * std::sin(direction), yaw);
  }
  std::normal_distribution<double> gauss(0.0, 1.0);
  Eigen::Vector3d direction;
  do {
    direction = Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng));
  } while (direction.norm() < 1e-12);
  Eigen::Vector4d q;
  do {
    q = Eigen::Vector4d(gauss(rng), gauss(rng), gauss(rng), gauss(rng));
  } while (q.norm() < 1e-12);
  q.normalize();
  Pose pose;
  pose.translation = direction.normalized() * (radius * std::cbrt(unit(rng)));
  pose.rotation = Eigen::Quaterniond(q(0), q(1), q(2), q(3));
  return pose;
}

Edge outlierEdge(int from, int to, const Pose& measurement, const Eigen::MatrixXd& information) {
  Edge edge;
  edge.from = from;
  edge.to = to;
  edge.measurement = measurement;
  edge.information = information;
  edge.kind = EdgeKind::kLoopClosure;
  edge.is_outlier = true;
  return edge;
}

// What placing the outliers of one graph shares: the reference poses they
// must contradict, their information, the random draws (one generator, in
// the order riSAM's protocol draws, so that a seed keeps its outliers), how
// many are wanted and where they may go, and the edges they are added to.
struct Placement {
  const PoseGraph& graph;
  const PoseGraph& reference;
  Eigen::MatrixXd information;
  double gate;  // chi-square q(0.95) of the tangent dimension
  std::mt19937_64 rng;
  int wanted;
  int min_separation, max_separation;  // of the two endpoints, in poses
  long long total_pairs;               // pose pairs at an allowed separation
  std::vector<Edge>* edges;

  // An outlier measurement that the true relative pose explains within the
  // 95 % gate would be a true loop, not an outlier. The gate compares the
  // Mahalanobis distance r (not r^2) with the quantile, as the reference
  // implementations' tests do (ALGORITHM.md §1, §3), so that every injected
  // outlier is an outlier under the engine's default classification too.
  bool contradictsTruth(int i, int j, const Pose& measurement) const {
    const Eigen::VectorXd error =
        relativePoseError(graph.dimension, reference.poses[i], reference.poses[j], measurement);
    return std::sqrt(error.dot(information * error)) >= gate;
  }
};

// One identity-pose outlier per drawn pair (i, j), i > j: `draw` returns the
// next pair, or false for a draw that is no pair at all. Every pair decided,
// accepted or rejected, is kept: a rejected pair would be rejected again, so
// skipping it does not change which pairs are chosen; it only makes "every
// pair tried" detectable instead of looping forever.
template <typename Draw>
void placeSingle(Placement* p, Draw draw, const char* kind) {
  std::set<std::pair<int, int>> decided;
  int added = 0;
  while (added < p->wanted) {
    int i = 0, j = 0;
    if (!draw(&i, &j)) continue;
    if (!decided.insert({i, j}).second) {
      if (static_cast<long long>(decided.size()) == p->total_pairs) {
        throw std::runtime_error("injectOutliers: only " + std::to_string(added) + " of " +
                                 std::to_string(p->wanted) + kind + " outliers are inconsistent with the reference");
      }
      continue;
    }
    if (!p->contradictsTruth(i, j, Pose::identity())) continue;
    p->edges->push_back(outlierEdge(i, j, Pose::identity(), p->information));
    ++added;
  }
}

// riSAM's protocol: two poses drawn uniformly, kept if i - j >= 2.
void placeRandom(Placement* p) {
  std::uniform_int_distribution<int> draw_pose(0, static_cast<int>(p->graph.poses.size()) - 1);
  placeSingle(
      p,
      [&](int* i, int* j) {
        *i = draw_pose(p->rng);
        *j = draw_pose(p->rng);
        return *i - *j >= 2;  // enforces i > j and |i - j| >= 2
      },
      "");
}

// Newer endpoint i in [min, N - 1], separation d in [min, min(max, i)].
void placeLocal(Placement* p) {
  std::uniform_int_distribution<int> draw_newer(p->min_separation, static_cast<int>(p->graph.poses.size()) - 1);
  placeSingle(
      p,
      [&](int* i, int* j) {
        *i = draw_newer(p->rng);
        std::uniform_int_distribution<int> draw_separation(p->min_separation, std::min(p->max_separation, *i));
        *j = *i - draw_separation(p->rng);
        return true;
      },
      " local");
}

// Groups of `group_size` consecutive pose pairs (i + k, j + k) sharing one
// random wrong measurement; a group is placed whole or drawn again.
void placeGroups(Placement* p, bool local, int group_size) {
  const int num_poses = static_cast<int>(p->graph.poses.size());
  const double radius = typicalLoopLength(p->graph);
  std::set<std::pair<int, int>> used;
  int added = 0, failed_draws = 0;
  while (added < p->wanted) {
    const int size = std::min(group_size, p->wanted - added);
    // The group's newest pair is (i + size - 1, j + size - 1): i <= N - size.
    const int last_start = num_poses - size;
    if (last_start < p->min_separation) {
      throw std::invalid_argument("injectOutliers: " + std::to_string(num_poses) + " poses cannot hold a group of " +
                                  std::to_string(size) + " outliers " + std::to_string(p->min_separation) +
                                  " or more poses apart");
    }
    int i = 0, j = 0;
    if (local) {
      std::uniform_int_distribution<int> draw_newer(p->min_separation, last_start);
      i = draw_newer(p->rng);
      std::uniform_int_distribution<int> draw_separation(p->min_separation, std::min(p->max_separation, i));
      j = i - draw_separation(p->rng);
    } else {
      std::uniform_int_distribution<int> draw_pose(0, last_start);
      i = draw_pose(p->rng);
      j = draw_pose(p->rng);
    }
    const Pose measurement = randomMeasurement(p->graph.dimension, radius, p->rng);
    bool accepted = i - j >= 2;
    for (int k = 0; accepted && k < size; ++k) {
      accepted = !used.count({i + k, j + k}) && p->contradictsTruth(i + k, j + k, measurement);
    }
    if (!accepted) {
      if (++failed_draws == kMaxFailedGroupDraws) {
        throw std::runtime_error("injectOutliers: only " + std::to_string(added) + " of " +
                                 std::to_string(p->wanted) + " grouped outliers placed; " +
                                 std::to_string(kMaxFailedGroupDraws) + " draws of the next group in a row failed");
      }
      continue;
    }
    failed_draws = 0;
    for (int k = 0; k < size; ++k) {
      used.insert({i + k, j + k});
      p->edges->push_back(outlierEdge(i + k, j + k, measurement, p->information));
    }
    added += size;
  }
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

std::string toString(OutlierMode mode) {
  switch (mode) {
    case OutlierMode::kRandom: return "random";
    case OutlierMode::kLocal: return "local";
    case OutlierMode::kRandomGrouped: return "random-grouped";
    case OutlierMode::kLocalGrouped: return "local-grouped";
  }
  throw std::invalid_argument("toString: unknown OutlierMode " + std::to_string(static_cast<int>(mode)));
}

OutlierMode parseOutlierMode(const std::string& text) {
  for (OutlierMode mode :
       {OutlierMode::kRandom, OutlierMode::kLocal, OutlierMode::kRandomGrouped, OutlierMode::kLocalGrouped}) {
    if (text == toString(mode)) return mode;
  }
  throw std::invalid_argument("outlier mode must be random, local, random-grouped or local-grouped, got '" + text +
                              "'");
}

bool isGrouped(OutlierMode mode) {
  return mode == OutlierMode::kRandomGrouped || mode == OutlierMode::kLocalGrouped;
}

bool isLocal(OutlierMode mode) { return mode == OutlierMode::kLocal || mode == OutlierMode::kLocalGrouped; }

void validate(const OutlierOptions& options) {
  if (!(options.percent >= 0.0 && options.percent < 100.0)) {
    throw std::invalid_argument("OutlierOptions.percent must be in [0, 100), got " + std::to_string(options.percent));
  }
  toString(options.mode);  // throws for a value outside the enum
  if (options.group_size < 1) {
    throw std::invalid_argument("OutlierOptions.group_size must be at least 1, got " +
                                std::to_string(options.group_size));
  }
  if (options.local_min_separation < 2) {
    throw std::invalid_argument("OutlierOptions.local_min_separation must be at least 2, got " +
                                std::to_string(options.local_min_separation));
  }
  if (options.local_max_separation < options.local_min_separation) {
    throw std::invalid_argument("OutlierOptions.local_max_separation (" +
                                std::to_string(options.local_max_separation) +
                                ") must be at least local_min_separation (" +
                                std::to_string(options.local_min_separation) + ")");
  }
}

PoseGraph injectOutliers(const PoseGraph& graph, const PoseGraph& reference, const std::string& dataset_name,
                         const OutlierOptions& options) {
  validate(options);
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
  const bool local = isLocal(options.mode);
  Placement placement{graph, reference, {}, {}, std::mt19937_64(options.seed), num_outliers,
                      local ? options.local_min_separation : 2,
                      local ? options.local_max_separation : num_poses - 1, 0, &result.edges};
  placement.total_pairs = local ? localPairCount(num_poses, placement.min_separation, placement.max_separation)
                                : candidatePairCount(num_poses);
  if (num_outliers > placement.total_pairs) {
    throw std::invalid_argument("injectOutliers: " + std::to_string(num_outliers) + " outliers requested but only " +
                                std::to_string(placement.total_pairs) + " pose pairs" +
                                (local ? " at the local separation" : ""));
  }
  const Eigen::VectorXd covariance = outlierCovariance(graph, dataset_name, options);
  placement.information = covariance.cwiseInverse().asDiagonal();
  placement.gate = chiSquareQuantile(graph.tangentDimension(), 0.95);

  switch (options.mode) {
    case OutlierMode::kRandom: placeRandom(&placement); break;
    case OutlierMode::kLocal: placeLocal(&placement); break;
    case OutlierMode::kRandomGrouped:
    case OutlierMode::kLocalGrouped: placeGroups(&placement, local, options.group_size); break;
  }
  return result;
}

PoseGraph injectOutliersAgainstOptimum(const PoseGraph& graph, const std::string& dataset_name,
                                       const OutlierOptions& options) {
  PoseGraph reference = graph;
  optimizeBatchGlobal(&reference);
  return injectOutliers(graph, reference, dataset_name, options);
}

}  // namespace core
}  // namespace agnc_pgo
