// Tests for riSAM-style outlier injection (ALGORITHM.md §5).
#include "agnc_pgo/eval/outlier_injection.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "shared_datasets.h"

#include <Eigen/Geometry>

#include "agnc_pgo/core/g2o_io.h"

namespace agnc_pgo {
namespace core {
namespace {

// chi2 quantiles at 0.95, hard-coded so the test checks the library's gate
// against independent numbers. The gate compares the Mahalanobis distance r
// itself (not r^2) with these: a pair is an outlier iff r >= q95.
constexpr double kChi2Q95Dof3 = 7.814727903251178;
constexpr double kChi2Q95Dof6 = 12.591587243743977;

Pose planarPose(double x, double y, double yaw) {
  Pose pose;
  pose.translation = Eigen::Vector3d(x, y, 0.0);
  pose.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  return pose;
}

// Mahalanobis distance r = sqrt(e^T Omega e) (not r^2) of the relative pose
// (q, t) from the identity. SE(2) error: the Pose2 Logmap [rho, theta], rho =
// V(theta)^-1 t, written in the half-angle form V^-1 = (theta / 2)
// [[cot(theta / 2), 1], [-1, cot(theta / 2)]]. SE(3) error: (t, 2 vec(q))
// with q taken in the w >= 0 hemisphere.
double distanceOfRelative(const Eigen::Quaterniond& q, const Eigen::Vector3d& t, const Eigen::VectorXd& covariance) {
  Eigen::VectorXd error(covariance.size());
  if (covariance.size() == 3) {
    const Eigen::Matrix3d R = q.toRotationMatrix();
    const double theta = std::atan2(R(1, 0), R(0, 0));
    if (std::abs(theta) < 1e-9) {
      error << t.x(), t.y(), theta;
    } else {
      const double half = theta / 2.0;
      const double cot = 1.0 / std::tan(half);
      error << half * (cot * t.x() + t.y()), half * (-t.x() + cot * t.y()), theta;
    }
  } else {
    const double sign = q.w() < 0 ? -1.0 : 1.0;
    error << t, 2.0 * sign * q.vec();
  }
  return std::sqrt((error.array().square() / covariance.array()).sum());
}

// r of the pose of j in i's frame from the identity, computed here from the
// pose data.
double distanceToIdentity(const PoseGraph& reference, int i, int j, const Eigen::VectorXd& covariance) {
  const Pose& a = reference.poses[i];
  const Pose& b = reference.poses[j];
  const Eigen::Quaterniond q = a.rotation.conjugate() * b.rotation;
  const Eigen::Vector3d t = a.rotation.conjugate() * (b.translation - a.translation);
  return distanceOfRelative(q, t, covariance);
}

// r of the pose of j in i's frame from a measurement z: the error z^-1 T_ij.
double distanceToMeasurement(const PoseGraph& reference, int i, int j, const Pose& z,
                             const Eigen::VectorXd& covariance) {
  const Pose& a = reference.poses[i];
  const Pose& b = reference.poses[j];
  const Eigen::Quaterniond q_ij = a.rotation.conjugate() * b.rotation;
  const Eigen::Vector3d t_ij = a.rotation.conjugate() * (b.translation - a.translation);
  const Eigen::Quaterniond q = z.rotation.conjugate() * q_ij;
  const Eigen::Vector3d t = z.rotation.conjugate() * (t_ij - z.translation);
  return distanceOfRelative(q, t, covariance);
}

// Spacing of the revisited spots. Under CSAIL's noise (sigma_x^2 = 0.015) two
// poses d spots apart are r = 0.15 d / sqrt(0.015) = 1.22 d apart: d <= 2 is
// consistent even by the old r^2 rule, 3 <= d <= 6 has q95 <= r^2 but r < q95
// (rejected now, accepted by an r^2 gate), d >= 7 has r >= q95 (outliers).
constexpr double kSpotSpacing = 0.15;

// N poses along x that revisit the same ten spots (x = 0.15 * (k % 10)), so
// many pose pairs are consistent with the identity under CSAIL's noise and
// must be rejected, while pairs >= 7 spots apart are not. `loops` true loop
// closures (k + 2 -> k) make L.
PoseGraph revisitingPlanarGraph(int num_poses, int loops) {
  PoseGraph graph;
  graph.dimension = 2;
  for (int k = 0; k < num_poses; ++k) graph.poses.push_back(planarPose(kSpotSpacing * (k % 10), 0.0, 0.0));
  for (int k = 0; k + 1 < num_poses; ++k) {
    Edge edge;
    edge.from = k;
    edge.to = k + 1;
    edge.measurement = planarPose(kSpotSpacing, 0.0, 0.0);
    edge.information = Eigen::Matrix3d::Identity() * 100.0;
    edge.kind = EdgeKind::kOdometry;
    graph.edges.push_back(edge);
  }
  for (int k = 0; k < loops; ++k) {
    Edge edge;
    edge.from = k + 2;
    edge.to = k;
    edge.measurement = planarPose(0.1, 0.0, 0.0);
    edge.information = Eigen::Matrix3d::Identity() * 50.0;
    edge.kind = EdgeKind::kLoopClosure;
    graph.edges.push_back(edge);
  }
  return graph;
}

// 3D graph on a helix with varying orientation and `loops` true loops.
PoseGraph helixGraph(int num_poses, int loops) {
  PoseGraph graph;
  graph.dimension = 3;
  for (int k = 0; k < num_poses; ++k) {
    Pose pose;
    pose.translation = Eigen::Vector3d(std::cos(0.3 * k), std::sin(0.3 * k), 0.02 * k);
    pose.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(0.3 * k, Eigen::Vector3d::UnitZ()) *
                                       Eigen::AngleAxisd(0.1 * k, Eigen::Vector3d::UnitX()));
    graph.poses.push_back(pose);
  }
  for (int k = 0; k + 1 < num_poses; ++k) {
    Edge edge;
    edge.from = k;
    edge.to = k + 1;
    edge.information = Eigen::MatrixXd::Identity(6, 6);
    edge.kind = EdgeKind::kOdometry;
    graph.edges.push_back(edge);
  }
  for (int k = 0; k < loops; ++k) {
    Edge edge;
    edge.from = k;
    edge.to = k + 5;
    edge.information = Eigen::MatrixXd::Identity(6, 6);
    edge.kind = EdgeKind::kLoopClosure;
    graph.edges.push_back(edge);
  }
  return graph;
}

bool sameEdge(const Edge& a, const Edge& b) {
  return a.from == b.from && a.to == b.to && a.kind == b.kind && a.is_outlier == b.is_outlier &&
         a.measurement.translation == b.measurement.translation &&
         a.measurement.rotation.coeffs() == b.measurement.rotation.coeffs() &&
         a.information.rows() == b.information.rows() && a.information.cols() == b.information.cols() &&
         a.information == b.information;
}

std::vector<std::pair<int, int>> injectedPairs(const PoseGraph& original, const PoseGraph& result) {
  std::vector<std::pair<int, int>> pairs;
  for (std::size_t k = original.edges.size(); k < result.edges.size(); ++k) {
    pairs.emplace_back(result.edges[k].from, result.edges[k].to);
  }
  return pairs;
}

// Every property §5 asks of an injected graph.
void expectValidInjection(const PoseGraph& original, const PoseGraph& reference, const PoseGraph& result,
                          int expected_outliers, const Eigen::VectorXd& covariance) {
  ASSERT_EQ(result.edges.size(), original.edges.size() + expected_outliers);
  EXPECT_EQ(result.dimension, original.dimension);
  ASSERT_EQ(result.poses.size(), original.poses.size());
  for (std::size_t k = 0; k < original.poses.size(); ++k) {
    EXPECT_EQ(result.poses[k].translation, original.poses[k].translation);
  }
  for (std::size_t k = 0; k < original.edges.size(); ++k) {
    EXPECT_TRUE(sameEdge(result.edges[k], original.edges[k])) << "original edge " << k << " changed";
  }
  const int n = static_cast<int>(original.poses.size());
  const int dof = original.dimension == 2 ? 3 : 6;
  const double threshold = dof == 3 ? kChi2Q95Dof3 : kChi2Q95Dof6;
  const Eigen::MatrixXd information = covariance.cwiseInverse().asDiagonal();
  std::set<std::pair<int, int>> seen;
  for (std::size_t k = original.edges.size(); k < result.edges.size(); ++k) {
    const Edge& edge = result.edges[k];
    EXPECT_TRUE(edge.is_outlier);
    EXPECT_EQ(edge.kind, EdgeKind::kLoopClosure);
    EXPECT_GE(edge.to, 0);
    EXPECT_LT(edge.from, n);
    EXPECT_GT(edge.from, edge.to);
    EXPECT_GE(edge.from - edge.to, 2);
    EXPECT_EQ(edge.measurement.translation, Eigen::Vector3d::Zero());
    EXPECT_EQ(edge.measurement.rotation.coeffs(), Eigen::Quaterniond::Identity().coeffs());
    ASSERT_EQ(edge.information.rows(), dof);
    ASSERT_EQ(edge.information.cols(), dof);
    EXPECT_TRUE(edge.information.isApprox(information, 1e-12));
    EXPECT_TRUE(seen.insert({edge.from, edge.to}).second) << "duplicate pair " << edge.from << "," << edge.to;
    // r itself, not r^2, must reach the quantile.
    EXPECT_GE(distanceToIdentity(reference, edge.from, edge.to, covariance), threshold)
        << "pair " << edge.from << "," << edge.to << " is consistent with the identity";
  }
}

int countOutliers(const PoseGraph& graph) {
  int count = 0;
  for (const Edge& edge : graph.edges) count += edge.is_outlier ? 1 : 0;
  return count;
}

// ---------------------------------------------------------- numOutliersFor

TEST(NumOutliersFor, MatchesIrlTable) {
  // L = CSAIL 128, Intel 895, Manhattan 2099, Sphere2500 2450 (shared/irl/README.md).
  EXPECT_EQ(numOutliersFor(128, 10.0), 14);
  EXPECT_EQ(numOutliersFor(895, 10.0), 99);
  EXPECT_EQ(numOutliersFor(2099, 10.0), 233);
  EXPECT_EQ(numOutliersFor(2450, 10.0), 272);
  EXPECT_EQ(numOutliersFor(128, 30.0), 54);
  EXPECT_EQ(numOutliersFor(895, 30.0), 383);
  EXPECT_EQ(numOutliersFor(2099, 30.0), 899);
  EXPECT_EQ(numOutliersFor(2450, 30.0), 1050);
  EXPECT_EQ(numOutliersFor(128, 50.0), 128);
  EXPECT_EQ(numOutliersFor(895, 50.0), 895);
  EXPECT_EQ(numOutliersFor(2099, 50.0), 2099);
  EXPECT_EQ(numOutliersFor(2450, 50.0), 2450);
}

TEST(NumOutliersFor, ExactQuotientsDoNotLoseOne) {
  EXPECT_EQ(numOutliersFor(0, 50.0), 0);
  EXPECT_EQ(numOutliersFor(100, 0.0), 0);
  EXPECT_EQ(numOutliersFor(7, 30.0), 3);       // 210 / 70
  EXPECT_EQ(numOutliersFor(70, 30.0), 30);     // 2100 / 70
  EXPECT_EQ(numOutliersFor(9, 10.0), 1);       // 90 / 90
  EXPECT_EQ(numOutliersFor(1, 90.0), 9);       // 90 / 10
  EXPECT_EQ(numOutliersFor(3, 100.0 / 3.0), 1);  // p / (100 - p) = 1/2 -> 1.5
  EXPECT_EQ(numOutliersFor(10, 100.0 / 3.0), 5);
  EXPECT_EQ(numOutliersFor(1, 99.0), 99);
  // Integer quotients that plain double arithmetic puts just below the
  // integer (e.g. 33.6 * 249 / 66.4 = 125.99999999999999).
  EXPECT_EQ(numOutliersFor(249, 33.6), 126);
  EXPECT_EQ(numOutliersFor(159, 36.4), 91);
  EXPECT_EQ(numOutliersFor(44, 64.8), 81);
}

TEST(NumOutliersFor, RejectsInvalidPercent) {
  EXPECT_THROW(numOutliersFor(10, -1.0), std::invalid_argument);
  EXPECT_THROW(numOutliersFor(10, 100.0), std::invalid_argument);
  EXPECT_THROW(numOutliersFor(10, 150.0), std::invalid_argument);
  EXPECT_THROW(numOutliersFor(10, std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
  EXPECT_THROW(numOutliersFor(-1, 10.0), std::invalid_argument);
}

// ------------------------------------------------- defaultOutlierCovariance

TEST(DefaultOutlierCovariance, PerDataset) {
  EXPECT_EQ(defaultOutlierCovariance("csail", 2), Eigen::Vector3d(0.015, 0.01, 0.001));
  EXPECT_EQ(defaultOutlierCovariance("CSAIL_10", 2), Eigen::Vector3d(0.015, 0.01, 0.001));
  EXPECT_EQ(defaultOutlierCovariance("intel.g2o", 2), Eigen::Vector3d(0.0024, 0.0024, 0.0002));
  EXPECT_EQ(defaultOutlierCovariance("INTEL", 2), Eigen::Vector3d(0.0024, 0.0024, 0.0002));
  EXPECT_EQ(defaultOutlierCovariance("manhattanOlson3500", 2), Eigen::Vector3d(0.0224, 0.0224, 0.0224));
  EXPECT_EQ(defaultOutlierCovariance("/data/MANHATTAN_30.irl", 2), Eigen::Vector3d(0.0224, 0.0224, 0.0224));
  Eigen::VectorXd sphere(6);
  sphere << 0.1, 0.1, 0.1, 0.0025, 0.0025, 0.0025;
  EXPECT_EQ(defaultOutlierCovariance("Sphere2500", 3), sphere);
}

TEST(DefaultOutlierCovariance, UnknownNamesFallBack) {
  EXPECT_EQ(defaultOutlierCovariance("ring", 2), Eigen::Vector3d(0.015, 0.01, 0.001));
  EXPECT_EQ(defaultOutlierCovariance("", 2), Eigen::Vector3d(0.015, 0.01, 0.001));
  Eigen::VectorXd sphere(6);
  sphere << 0.1, 0.1, 0.1, 0.0025, 0.0025, 0.0025;
  EXPECT_EQ(defaultOutlierCovariance("smallGrid3D", 3), sphere);
  EXPECT_THROW(defaultOutlierCovariance("csail", 4), std::invalid_argument);
}

// ---------------------------------------------------- injectOutliers (hand)

TEST(InjectOutliers, PlanarGraphSatisfiesAllConstraints) {
  const PoseGraph graph = revisitingPlanarGraph(60, 30);
  OutlierOptions options;
  options.percent = 50.0;
  options.seed = 42;
  const PoseGraph result = injectOutliers(graph, graph, "csail", options);
  expectValidInjection(graph, graph, result, 30, defaultOutlierCovariance("csail", 2));
  EXPECT_EQ(countOutliers(result), 30);
  // Only pairs >= 7 spots apart (r >= q95) qualify; 3..6 spots apart would
  // pass an r^2 gate but not this one.
  for (const auto& pair : injectedPairs(graph, result)) {
    const int spots = std::abs(pair.first % 10 - pair.second % 10);
    EXPECT_GE(spots, 7) << "pair " << pair.first << "," << pair.second;
  }
}

// The fixture must actually contain pairs that the gate rejects, including
// pairs that only the r (not r^2) comparison rejects, otherwise the
// consistency test above would pass vacuously.
TEST(InjectOutliers, FixtureHasConsistentPairs) {
  const PoseGraph graph = revisitingPlanarGraph(60, 30);
  const Eigen::VectorXd covariance = defaultOutlierCovariance("csail", 2);
  int consistent = 0;     // r^2 < q95
  int squared_only = 0;   // q95 <= r^2 but r < q95
  int inconsistent = 0;   // r >= q95
  for (int i = 0; i < 60; ++i) {
    for (int j = 0; j + 2 <= i; ++j) {
      const double r = distanceToIdentity(graph, i, j, covariance);
      if (r >= kChi2Q95Dof3) {
        ++inconsistent;
      } else if (r * r >= kChi2Q95Dof3) {
        ++squared_only;
      } else {
        ++consistent;
      }
    }
  }
  // 6 poses per spot: 6 spot pairs are >= 7 apart (36 pose pairs each, less
  // the 5 lap changes 10m + 9 -> 10m + 10, which are adjacent), 22 are 3..6 apart.
  EXPECT_EQ(inconsistent, 6 * 36 - 5);
  EXPECT_EQ(squared_only, 22 * 36);
  EXPECT_EQ(consistent + squared_only + inconsistent, 59 * 58 / 2);
}

// The gate compares r = sqrt(e^T Omega e) with q95, not r^2. Three poses leave
// a single candidate pair (2, 0), so the library must take it or throw.
TEST(InjectOutliers, GateUsesDistanceNotItsSquare) {
  const Eigen::VectorXd covariance = defaultOutlierCovariance("csail", 2);
  const double sigma_x = std::sqrt(covariance(0));
  OutlierOptions options;
  options.percent = 50.0;  // L = 1 -> one outlier
  PoseGraph graph = revisitingPlanarGraph(3, 1);
  ASSERT_EQ(numOutliersFor(1, 50.0), 1);

  // 0.6 m along x: r = 0.6 / sqrt(0.015) = 4.899, r^2 = 24 >= 7.81 > r.
  graph.poses[0] = planarPose(0.0, 0.0, 0.0);
  graph.poses[2] = planarPose(0.6, 0.0, 0.0);
  const double r = distanceToIdentity(graph, 2, 0, covariance);
  EXPECT_NEAR(r, 0.6 / sigma_x, 1e-12);
  ASSERT_GE(r * r, kChi2Q95Dof3);
  ASSERT_LT(r, kChi2Q95Dof3);
  EXPECT_THROW(injectOutliers(graph, graph, "csail", options), std::runtime_error);

  // Just below and just above r = q95.
  graph.poses[2] = planarPose(sigma_x * kChi2Q95Dof3 * (1.0 - 1e-9), 0.0, 0.0);
  ASSERT_LT(distanceToIdentity(graph, 2, 0, covariance), kChi2Q95Dof3);
  EXPECT_THROW(injectOutliers(graph, graph, "csail", options), std::runtime_error);

  graph.poses[2] = planarPose(sigma_x * kChi2Q95Dof3 * (1.0 + 1e-9), 0.0, 0.0);
  ASSERT_GE(distanceToIdentity(graph, 2, 0, covariance), kChi2Q95Dof3);
  const PoseGraph result = injectOutliers(graph, graph, "csail", options);
  expectValidInjection(graph, graph, result, 1, covariance);
  ASSERT_EQ(injectedPairs(graph, result), (std::vector<std::pair<int, int>>{{2, 0}}));

  // The residual gated is the SE(2) Logmap, |rho| = |t| (theta/2) / sin(theta/2).
  // Under noise (0.01, 0.01, 1) a quarter turn with |t| = 0.73 has
  // r^2 = 0.5329 (pi^2 / 8) / 0.01 + pi^2 / 4 = 6.91125 pi^2 = 68.21 (r = 8.26 >= q95),
  // while the plain [t, theta] would give r^2 = 53.29 + pi^2 / 4 = 55.76 (r = 7.47 < q95).
  options.covariance_diagonal = Eigen::Vector3d(0.01, 0.01, 1.0);
  graph.poses[2] = planarPose(0.73, 0.0, M_PI / 2);
  const double logmap_r = distanceToIdentity(graph, 2, 0, options.covariance_diagonal);
  EXPECT_NEAR(logmap_r * logmap_r, 6.91125 * M_PI * M_PI, 1e-9);
  ASSERT_GE(logmap_r, kChi2Q95Dof3);
  ASSERT_LT(std::sqrt(53.29 + M_PI * M_PI / 4.0), kChi2Q95Dof3);
  const PoseGraph rotated = injectOutliers(graph, graph, "csail", options);
  expectValidInjection(graph, graph, rotated, 1, options.covariance_diagonal);
  EXPECT_EQ(injectedPairs(graph, rotated), (std::vector<std::pair<int, int>>{{2, 0}}));
  // Same translation without the turn: r = 7.3 < q95, rejected.
  graph.poses[2] = planarPose(0.73, 0.0, 0.0);
  EXPECT_NEAR(distanceToIdentity(graph, 2, 0, options.covariance_diagonal), 7.3, 1e-12);
  EXPECT_THROW(injectOutliers(graph, graph, "csail", options), std::runtime_error);
}

TEST(InjectOutliers, SpatialGraphSatisfiesAllConstraints) {
  const PoseGraph graph = helixGraph(80, 40);
  OutlierOptions options;
  options.percent = 30.0;
  options.seed = 3;
  const PoseGraph result = injectOutliers(graph, graph, "sphere2500", options);
  expectValidInjection(graph, graph, result, numOutliersFor(40, 30.0), defaultOutlierCovariance("sphere", 3));
}

TEST(InjectOutliers, UsesExplicitCovariance) {
  // Spread the poses out (2 m apart): under this wide noise the revisiting
  // layout would have no inconsistent pair at all.
  PoseGraph graph = revisitingPlanarGraph(60, 20);
  for (std::size_t k = 0; k < graph.poses.size(); ++k) graph.poses[k] = planarPose(2.0 * k, 0.0, 0.0);
  OutlierOptions options;
  options.percent = 10.0;
  options.covariance_diagonal = Eigen::Vector3d(0.5, 0.25, 0.125);
  const PoseGraph result = injectOutliers(graph, graph, "csail", options);
  expectValidInjection(graph, graph, result, 2, options.covariance_diagonal);
  EXPECT_TRUE(result.edges.back().information.isApprox(Eigen::Vector3d(2, 4, 8).asDiagonal().toDenseMatrix()));
}

TEST(InjectOutliers, RejectsBadCovariance) {
  const PoseGraph graph = revisitingPlanarGraph(30, 10);
  OutlierOptions options;
  options.percent = 50.0;
  options.covariance_diagonal = Eigen::VectorXd::Ones(6);
  EXPECT_THROW(injectOutliers(graph, graph, "csail", options), std::invalid_argument);
  options.covariance_diagonal = Eigen::Vector3d(0.1, 0.0, 0.1);
  EXPECT_THROW(injectOutliers(graph, graph, "csail", options), std::invalid_argument);
}

TEST(InjectOutliers, UsesReferenceForTheGate) {
  // Graph poses all identical (every pair would pass the gate), reference spread out.
  PoseGraph graph = revisitingPlanarGraph(40, 20);
  const PoseGraph reference = graph;
  for (Pose& pose : graph.poses) pose = Pose();
  OutlierOptions options;
  options.percent = 50.0;
  const PoseGraph result = injectOutliers(graph, reference, "csail", options);
  expectValidInjection(graph, reference, result, 20, defaultOutlierCovariance("csail", 2));
  // Gated on the graph's own (identical) poses, no pair would qualify.
  EXPECT_THROW(injectOutliers(graph, graph, "csail", options), std::runtime_error);
}

TEST(InjectOutliers, DeterministicPerSeed) {
  const PoseGraph graph = revisitingPlanarGraph(100, 40);
  OutlierOptions options;
  options.percent = 30.0;
  options.seed = 123;
  const PoseGraph a = injectOutliers(graph, graph, "csail", options);
  const PoseGraph b = injectOutliers(graph, graph, "csail", options);
  ASSERT_EQ(a.edges.size(), b.edges.size());
  for (std::size_t k = 0; k < a.edges.size(); ++k) EXPECT_TRUE(sameEdge(a.edges[k], b.edges[k]));
  options.seed = 124;
  const PoseGraph c = injectOutliers(graph, graph, "csail", options);
  ASSERT_EQ(c.edges.size(), a.edges.size());
  EXPECT_NE(injectedPairs(graph, a), injectedPairs(graph, c));
}

TEST(InjectOutliers, ZeroPercentReturnsCopy) {
  const PoseGraph graph = revisitingPlanarGraph(20, 5);
  OutlierOptions options;
  options.percent = 0.0;
  const PoseGraph result = injectOutliers(graph, graph, "csail", options);
  ASSERT_EQ(result.edges.size(), graph.edges.size());
  for (std::size_t k = 0; k < graph.edges.size(); ++k) EXPECT_TRUE(sameEdge(result.edges[k], graph.edges[k]));
}

TEST(InjectOutliers, CountsOnlyTrueLoops) {
  // Injecting into an already spoiled graph must not grow L.
  const PoseGraph graph = revisitingPlanarGraph(60, 20);
  OutlierOptions options;
  options.percent = 50.0;
  const PoseGraph once = injectOutliers(graph, graph, "csail", options);
  options.seed = 9;
  const PoseGraph twice = injectOutliers(once, graph, "csail", options);
  EXPECT_EQ(countOutliers(once), 20);
  EXPECT_EQ(countOutliers(twice), 40);
  // The second round adds floor(50 * 20 / 50) = 20 (not 40) valid outliers.
  expectValidInjection(once, graph, twice, 20, defaultOutlierCovariance("csail", 2));
}

TEST(InjectOutliers, RejectsBadGraphs) {
  OutlierOptions options;
  options.percent = 50.0;
  // Two poses but one (artificial) loop closure: no valid pair exists.
  PoseGraph tiny;
  tiny.poses.resize(2);
  Edge loop;
  loop.from = 1;
  loop.to = 0;
  loop.kind = EdgeKind::kLoopClosure;
  loop.information = Eigen::Matrix3d::Identity();
  tiny.edges.push_back(loop);
  EXPECT_THROW(injectOutliers(tiny, tiny, "csail", options), std::invalid_argument);
  // Reference with a different pose count.
  const PoseGraph graph = revisitingPlanarGraph(30, 10);
  const PoseGraph shorter = revisitingPlanarGraph(29, 10);
  EXPECT_THROW(injectOutliers(graph, shorter, "csail", options), std::invalid_argument);
}

TEST(InjectOutliers, ThrowsInsteadOfLoopingWhenEveryPairIsConsistent) {
  // All poses identical: every pair agrees with the identity, none may be used.
  PoseGraph graph = revisitingPlanarGraph(6, 3);
  for (Pose& pose : graph.poses) pose = Pose();
  OutlierOptions options;
  options.percent = 50.0;
  EXPECT_THROW(injectOutliers(graph, graph, "csail", options), std::runtime_error);
}

// ------------------------------------------- injectOutliers (random, fixed)

// The first outliers of kRandom, recorded from the implementation before the
// other modes existed: the mode must keep drawing exactly these pairs.
TEST(InjectOutliersModes, RandomModeUnchanged) {
  {
    const PoseGraph graph = revisitingPlanarGraph(100, 40);
    OutlierOptions options;
    options.percent = 30.0;
    options.seed = 123;
    const std::vector<std::pair<int, int>> expected = {
        {81, 48}, {71, 28}, {69, 2}, {79, 62}, {81, 68}, {19, 11}, {47, 10}, {99, 0}, {49, 12},
        {48, 30}, {59, 11}, {69, 12}, {91, 69}, {59, 40}, {47, 30}, {68, 30}, {59, 1}};
    EXPECT_EQ(injectedPairs(graph, injectOutliers(graph, graph, "csail", options)), expected);
    // The group size does not matter outside the grouped modes.
    options.group_size = 3;
    EXPECT_EQ(injectedPairs(graph, injectOutliers(graph, graph, "csail", options)), expected);
  }
  {
    const PoseGraph graph = helixGraph(80, 40);
    OutlierOptions options;
    options.percent = 30.0;
    options.seed = 3;
    const std::vector<std::pair<int, int>> expected = {
        {44, 15}, {47, 27}, {44, 28}, {58, 33}, {56, 13}, {20, 1}, {78, 39}, {30, 17}, {65, 20},
        {52, 43}, {59, 7}, {71, 34}, {77, 51}, {74, 48}, {36, 8}, {76, 71}, {61, 14}};
    EXPECT_EQ(injectedPairs(graph, injectOutliers(graph, graph, "sphere2500", options)), expected);
  }
}

// ------------------------------------------------ injectOutliers (modes)

TEST(OutlierModeNames, RoundTripAndRejectUnknown) {
  for (OutlierMode mode :
       {OutlierMode::kRandom, OutlierMode::kLocal, OutlierMode::kRandomGrouped, OutlierMode::kLocalGrouped}) {
    EXPECT_EQ(parseOutlierMode(toString(mode)), mode);
  }
  EXPECT_EQ(toString(OutlierMode::kLocalGrouped), "local-grouped");
  EXPECT_FALSE(isGrouped(OutlierMode::kLocal));
  EXPECT_TRUE(isGrouped(OutlierMode::kRandomGrouped));
  EXPECT_TRUE(isLocal(OutlierMode::kLocalGrouped));
  EXPECT_FALSE(isLocal(OutlierMode::kRandomGrouped));
  for (const char* bad : {"grouped", "Random", "", "local_grouped"}) {
    try {
      parseOutlierMode(bad);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("random, local, random-grouped or local-grouped"), std::string::npos);
    }
  }
}

void expectInvalidField(const OutlierOptions& options, const std::string& field) {
  const PoseGraph graph = revisitingPlanarGraph(100, 40);
  try {
    injectOutliers(graph, graph, "csail", options);
    ADD_FAILURE() << "accepted invalid " << field;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
  }
}

TEST(InjectOutliersModes, ValidatesOptions) {
  OutlierOptions options;
  options.mode = OutlierMode::kRandomGrouped;
  options.group_size = 0;
  expectInvalidField(options, "group_size");
  options.group_size = -3;
  expectInvalidField(options, "group_size");
  options = OutlierOptions();
  options.mode = OutlierMode::kLocal;
  options.local_min_separation = 1;
  expectInvalidField(options, "local_min_separation");
  options.local_min_separation = 30;
  options.local_max_separation = 29;
  expectInvalidField(options, "local_max_separation");
  options = OutlierOptions();
  options.percent = 100.0;
  expectInvalidField(options, "percent");
  options = OutlierOptions();
  options.mode = static_cast<OutlierMode>(17);
  EXPECT_THROW(validate(options), std::invalid_argument);
  EXPECT_NO_THROW(validate(OutlierOptions()));
  EXPECT_EQ(OutlierOptions().mode, OutlierMode::kRandom);
  EXPECT_EQ(OutlierOptions().group_size, 10);
  EXPECT_EQ(OutlierOptions().local_min_separation, 20);
  EXPECT_EQ(OutlierOptions().local_max_separation, 50);
}

// Median length of the true loop closures' measurements, 1 m if that is 0
// (the radius of the grouped modes' shared measurement).
double medianLoopLength(const PoseGraph& graph) {
  std::vector<double> lengths;
  for (const Edge& edge : graph.edges) {
    if (edge.kind == EdgeKind::kLoopClosure && !edge.is_outlier) lengths.push_back(edge.measurement.translation.norm());
  }
  std::sort(lengths.begin(), lengths.end());
  const std::size_t n = lengths.size();
  const double median = n % 2 ? lengths[n / 2] : 0.5 * (lengths[n / 2 - 1] + lengths[n / 2]);
  return median > 0.0 ? median : 1.0;
}

bool samePose(const Pose& a, const Pose& b) {
  return a.translation == b.translation && a.rotation.coeffs() == b.rotation.coeffs();
}

// Checks the geometry of `mode` on an injected graph: the count, |i - j|,
// groups (consecutive pairs, one shared measurement, of group_size except
// the last), the gate against the reference, no pair twice; returns the
// groups' first pairs.
std::vector<std::pair<int, int>> expectModeGeometry(const PoseGraph& original, const PoseGraph& reference,
                                                    const PoseGraph& result, const OutlierOptions& options,
                                                    const Eigen::VectorXd& covariance) {
  const int expected = numOutliersFor(static_cast<int>(std::count_if(original.edges.begin(), original.edges.end(),
                                                                     [](const Edge& e) {
                                                                       return e.kind == EdgeKind::kLoopClosure &&
                                                                              !e.is_outlier;
                                                                     })),
                                      options.percent);
  EXPECT_EQ(result.edges.size(), original.edges.size() + expected);
  for (std::size_t k = 0; k < original.edges.size(); ++k) {
    EXPECT_TRUE(sameEdge(result.edges[k], original.edges[k])) << "original edge " << k << " changed";
  }
  const int n = static_cast<int>(original.poses.size());
  const int dof = original.dimension == 2 ? 3 : 6;
  const double threshold = dof == 3 ? kChi2Q95Dof3 : kChi2Q95Dof6;
  const Eigen::MatrixXd information = covariance.cwiseInverse().asDiagonal();
  const bool grouped = isGrouped(options.mode);
  const int group = grouped ? options.group_size : 1;
  const double radius = grouped ? medianLoopLength(original) : 0.0;
  std::set<std::pair<int, int>> seen;
  std::vector<std::pair<int, int>> starts;
  const std::size_t first = original.edges.size();
  for (std::size_t k = first; k < result.edges.size(); ++k) {
    const Edge& edge = result.edges[k];
    const std::size_t member = (k - first) % group;
    EXPECT_TRUE(edge.is_outlier);
    EXPECT_EQ(edge.kind, EdgeKind::kLoopClosure);
    EXPECT_GE(edge.to, 0);
    EXPECT_LT(edge.from, n);
    const int separation = edge.from - edge.to;
    if (isLocal(options.mode)) {
      EXPECT_GE(separation, options.local_min_separation) << edge.from << "," << edge.to;
      EXPECT_LE(separation, options.local_max_separation) << edge.from << "," << edge.to;
    } else {
      EXPECT_GE(separation, 2) << edge.from << "," << edge.to;
    }
    EXPECT_TRUE(edge.information.isApprox(information, 1e-12));
    EXPECT_TRUE(seen.insert({edge.from, edge.to}).second) << "duplicate pair " << edge.from << "," << edge.to;
    EXPECT_GE(distanceToMeasurement(reference, edge.from, edge.to, edge.measurement, covariance), threshold)
        << "pair " << edge.from << "," << edge.to << " is consistent with its measurement";
    if (!grouped) {
      EXPECT_TRUE(samePose(edge.measurement, Pose::identity()));
      starts.emplace_back(edge.from, edge.to);
      continue;
    }
    EXPECT_FALSE(samePose(edge.measurement, Pose::identity()));
    EXPECT_LE(edge.measurement.translation.norm(), radius * (1 + 1e-12));
    EXPECT_NEAR(edge.measurement.rotation.norm(), 1.0, 1e-12);
    if (original.dimension == 2) {
      EXPECT_EQ(edge.measurement.translation.z(), 0.0);
      EXPECT_NEAR(edge.measurement.rotation.x(), 0.0, 1e-15);
      EXPECT_NEAR(edge.measurement.rotation.y(), 0.0, 1e-15);
    }
    if (member == 0) {
      starts.emplace_back(edge.from, edge.to);
    } else {
      // A member of the group begun at `first + k - member`: the next pair, the same measurement.
      const Edge& previous = result.edges[k - 1];
      EXPECT_EQ(edge.from, previous.from + 1);
      EXPECT_EQ(edge.to, previous.to + 1);
      EXPECT_TRUE(samePose(edge.measurement, previous.measurement)) << "group member " << member << " at " << k;
    }
  }
  return starts;
}

OutlierOptions modeOptions(OutlierMode mode, double percent, std::uint64_t seed) {
  OutlierOptions options;
  options.mode = mode;
  options.percent = percent;
  options.seed = seed;
  return options;
}

TEST(InjectOutliersModes, LocalStaysWithinRange) {
  const PoseGraph graph = revisitingPlanarGraph(200, 60);
  const Eigen::VectorXd covariance = defaultOutlierCovariance("csail", 2);
  const OutlierOptions options = modeOptions(OutlierMode::kLocal, 30.0, 5);
  const PoseGraph result = injectOutliers(graph, graph, "csail", options);
  const auto pairs = expectModeGeometry(graph, graph, result, options, covariance);
  EXPECT_EQ(pairs.size(), 25u);  // floor(30 * 60 / 70)
  // Both ends of the range are reachable: a narrow range is honoured exactly.
  OutlierOptions narrow = options;
  narrow.local_min_separation = 27;
  narrow.local_max_separation = 28;
  const PoseGraph narrowed = injectOutliers(graph, graph, "csail", narrow);
  std::set<int> separations;
  for (const auto& pair : expectModeGeometry(graph, graph, narrowed, narrow, covariance)) {
    separations.insert(pair.first - pair.second);
  }
  EXPECT_EQ(separations, (std::set<int>{27, 28}));
}

TEST(InjectOutliersModes, LocalSpatial) {
  const PoseGraph graph = helixGraph(150, 60);
  const OutlierOptions options = modeOptions(OutlierMode::kLocal, 30.0, 8);
  const PoseGraph result = injectOutliers(graph, graph, "sphere2500", options);
  EXPECT_EQ(expectModeGeometry(graph, graph, result, options, defaultOutlierCovariance("sphere", 3)).size(), 25u);
}

TEST(InjectOutliersModes, LocalNeedsEnoughPoses) {
  // 20 poses have no pair 20 or more apart.
  const PoseGraph graph = revisitingPlanarGraph(20, 10);
  for (OutlierMode mode : {OutlierMode::kLocal, OutlierMode::kLocalGrouped}) {
    EXPECT_THROW(injectOutliers(graph, graph, "csail", modeOptions(mode, 50.0, 1)), std::invalid_argument);
  }
}

TEST(InjectOutliersModes, RandomGroupedShareOneMeasurement) {
  const PoseGraph graph = revisitingPlanarGraph(300, 80);
  const OutlierOptions options = modeOptions(OutlierMode::kRandomGrouped, 30.0, 11);
  const PoseGraph result = injectOutliers(graph, graph, "csail", options);
  // floor(30 * 80 / 70) = 34 outliers: three groups of 10 and one of 4.
  const auto starts = expectModeGeometry(graph, graph, result, options, defaultOutlierCovariance("csail", 2));
  EXPECT_EQ(starts.size(), 4u);
  // Groups draw their own measurements.
  const std::size_t first = graph.edges.size();
  EXPECT_FALSE(samePose(result.edges[first].measurement, result.edges[first + 10].measurement));
}

TEST(InjectOutliersModes, LocalGroupedShareOneMeasurementWithinRange) {
  const PoseGraph graph = revisitingPlanarGraph(300, 80);
  OutlierOptions options = modeOptions(OutlierMode::kLocalGrouped, 30.0, 12);
  const PoseGraph result = injectOutliers(graph, graph, "csail", options);
  EXPECT_EQ(expectModeGeometry(graph, graph, result, options, defaultOutlierCovariance("csail", 2)).size(), 4u);
  // Other group sizes: 7 -> 4 groups of 7 and one of 6; 1 -> 34 single outliers; 50 -> one group of 34.
  for (const auto& [size, groups] : std::vector<std::pair<int, std::size_t>>{{7, 5}, {1, 34}, {50, 1}}) {
    options.group_size = size;
    const PoseGraph sized = injectOutliers(graph, graph, "csail", options);
    EXPECT_EQ(expectModeGeometry(graph, graph, sized, options, defaultOutlierCovariance("csail", 2)).size(), groups)
        << "group size " << size;
  }
}

TEST(InjectOutliersModes, GroupedSpatial) {
  const PoseGraph graph = helixGraph(200, 60);
  for (OutlierMode mode : {OutlierMode::kRandomGrouped, OutlierMode::kLocalGrouped}) {
    const OutlierOptions options = modeOptions(mode, 30.0, 13);
    const PoseGraph result = injectOutliers(graph, graph, "sphere2500", options);
    // helixGraph's loop measurements are identities: the radius falls back to 1 m.
    EXPECT_EQ(expectModeGeometry(graph, graph, result, options, defaultOutlierCovariance("sphere", 3)).size(), 3u)
        << toString(mode);
    for (std::size_t k = graph.edges.size(); k < result.edges.size(); ++k) {
      EXPECT_LE(result.edges[k].measurement.translation.norm(), 1.0);
    }
  }
}

TEST(InjectOutliersModes, GroupedGateUsesReference) {
  // Graph poses all identical, reference spread out: the members are gated
  // against the reference.
  PoseGraph graph = revisitingPlanarGraph(300, 60);
  const PoseGraph reference = graph;
  for (Pose& pose : graph.poses) pose = Pose();
  const OutlierOptions options = modeOptions(OutlierMode::kLocalGrouped, 50.0, 14);
  const PoseGraph result = injectOutliers(graph, reference, "csail", options);
  EXPECT_EQ(expectModeGeometry(graph, reference, result, options, defaultOutlierCovariance("csail", 2)).size(), 6u);
}

TEST(InjectOutliersModes, GroupedThrowsWhenTruthExplainsEverything) {
  // Every pose pair is the identity and the covariance is wide enough for any
  // measurement within the radius and any heading: no group can be placed.
  PoseGraph graph = revisitingPlanarGraph(40, 10);
  for (Pose& pose : graph.poses) pose = Pose();
  OutlierOptions options = modeOptions(OutlierMode::kRandomGrouped, 50.0, 1);
  options.covariance_diagonal = Eigen::Vector3d(1e4, 1e4, 1e4);
  EXPECT_THROW(injectOutliers(graph, graph, "csail", options), std::runtime_error);
}

TEST(InjectOutliersModes, DeterministicPerSeed) {
  const PoseGraph graph = revisitingPlanarGraph(300, 80);
  for (OutlierMode mode :
       {OutlierMode::kRandom, OutlierMode::kLocal, OutlierMode::kRandomGrouped, OutlierMode::kLocalGrouped}) {
    OutlierOptions options = modeOptions(mode, 30.0, 21);
    const PoseGraph a = injectOutliers(graph, graph, "csail", options);
    const PoseGraph b = injectOutliers(graph, graph, "csail", options);
    ASSERT_EQ(a.edges.size(), b.edges.size());
    for (std::size_t k = 0; k < a.edges.size(); ++k) EXPECT_TRUE(sameEdge(a.edges[k], b.edges[k])) << toString(mode);
    options.seed = 22;
    const PoseGraph c = injectOutliers(graph, graph, "csail", options);
    ASSERT_EQ(c.edges.size(), a.edges.size());
    EXPECT_NE(injectedPairs(graph, a), injectedPairs(graph, c)) << toString(mode);
  }
}

TEST(InjectOutliersModes, ModesDiffer) {
  const PoseGraph graph = revisitingPlanarGraph(300, 80);
  std::set<std::vector<std::pair<int, int>>> placements;
  for (OutlierMode mode :
       {OutlierMode::kRandom, OutlierMode::kLocal, OutlierMode::kRandomGrouped, OutlierMode::kLocalGrouped}) {
    placements.insert(injectedPairs(graph, injectOutliers(graph, graph, "csail", modeOptions(mode, 30.0, 1))));
  }
  EXPECT_EQ(placements.size(), 4u);
}

// ------------------------------------------------ injectOutliers (datasets)

std::string datasetPath(const std::string& name) {
  return std::string(AGNC_PGO_SHARED_DIR) + "/datasets/" + name;
}

TEST(InjectOutliersDataset, Csail) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  const PoseGraph graph = readG2o(datasetPath("csail.g2o"));
  ASSERT_EQ(graph.poses.size(), 1045u);
  for (double percent : {10.0, 30.0, 50.0}) {
    OutlierOptions options;
    options.percent = percent;
    options.seed = 2024;
    const PoseGraph result = injectOutliers(graph, graph, "csail", options);
    expectValidInjection(graph, graph, result, numOutliersFor(128, percent), defaultOutlierCovariance("csail", 2));
  }
  OutlierOptions options;
  options.percent = 10.0;
  EXPECT_EQ(injectOutliers(graph, graph, "csail", options).edges.size(), graph.edges.size() + 14);
}

TEST(InjectOutliersDataset, ManhattanAgainstGroundTruth) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  const PoseGraph graph = readG2o(datasetPath("manhattanOlson3500.g2o"));
  const PoseGraph truth = readG2o(datasetPath("manhattanOlson3500_gt.g2o"));
  ASSERT_EQ(graph.poses.size(), 3500u);
  ASSERT_EQ(truth.poses.size(), 3500u);
  OutlierOptions options;
  options.percent = 10.0;
  options.seed = 7;
  const PoseGraph result = injectOutliers(graph, truth, "manhattanOlson3500", options);
  expectValidInjection(graph, truth, result, 233, defaultOutlierCovariance("manhattan", 2));
  options.percent = 30.0;
  const PoseGraph thirty = injectOutliers(graph, truth, "manhattanOlson3500", options);
  EXPECT_EQ(thirty.edges.size(), graph.edges.size() + 899);
  const PoseGraph again = injectOutliers(graph, truth, "manhattanOlson3500", options);
  EXPECT_EQ(injectedPairs(graph, thirty), injectedPairs(graph, again));
}

}  // namespace
}  // namespace core
}  // namespace agnc_pgo
