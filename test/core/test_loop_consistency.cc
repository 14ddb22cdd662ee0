// Pairwise consistency of neighbouring loop closures: true loop closures
// agree with each other through the local trajectory however much the map
// has drifted; a false one does not.
#include "agnc_pgo/core/loop_consistency.h"

#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace agnc_pgo {
namespace core {
namespace {

// A trajectory that winds back on itself (poses 0..39 along a square-ish
// path), and an estimate of it whose second half drifted by a rigid motion:
// every local segment is exact, the loop closures' residuals are not.
struct DriftedTrajectory {
  std::vector<Pose, Eigen::aligned_allocator<Pose>> truth, estimate;
  int dimension;

  explicit DriftedTrajectory(int dim) : dimension(dim) {
    const Pose step = dim == 2 ? Pose::fromSE2(1.0, 0.0, 2.0 * M_PI / 20.0)
                               : Pose::fromXYZRPY(1.0, 0.0, 0.05, 0.02, -0.01, 2.0 * M_PI / 20.0);
    const Pose drift = dim == 2 ? Pose::fromSE2(4.0, -3.0, 0.4)
                                : Pose::fromXYZRPY(4.0, -3.0, 1.5, 0.1, 0.2, 0.4);
    Pose p;
    for (int i = 0; i < 40; ++i) {
      truth.push_back(p);
      estimate.push_back(i < 20 ? p : drift * p);
      p = p * step;
    }
  }

  Edge loop(int from, int to) const {
    Edge e;
    e.from = from;
    e.to = to;
    e.measurement = truth[from].inverse() * truth[to];
    const int n = dimension == 2 ? 3 : 6;
    e.information = 100.0 * Eigen::MatrixXd::Identity(n, n);
    return e;
  }

  double distance(const Edge& a, const Edge& b) const {
    // Exact odometry: only the loop closures are uncertain.
    const int n = dimension == 2 ? 3 : 6;
    return cycleDistance(dimension, a, b, [this](int id) { return estimate[id]; },
                         [n](int) { return Eigen::MatrixXd::Zero(n, n).eval(); });
  }

  // The whitened residual of a loop closure against the estimate.
  double residual(const Edge& e) const {
    const Eigen::VectorXd r = relativePoseError(dimension, estimate[e.from], estimate[e.to], e.measurement);
    return std::sqrt(r.dot(e.information * r));
  }
};

TEST(LoopConsistency, NeighboursAreMatchedInEitherDirection) {
  DriftedTrajectory t(2);
  const Edge a = t.loop(22, 2), b = t.loop(24, 3), reversed = t.loop(3, 24), far = t.loop(24, 12);
  EXPECT_TRUE(areNeighbours(a, b, 2));
  EXPECT_TRUE(areNeighbours(a, reversed, 2));
  EXPECT_FALSE(areNeighbours(a, b, 1));
  EXPECT_FALSE(areNeighbours(a, far, 5));
}

class LoopConsistencyIn : public ::testing::TestWithParam<int> {};

TEST_P(LoopConsistencyIn, TrueLoopClosuresAgreeDespiteTheDrift) {
  DriftedTrajectory t(GetParam());
  const Edge a = t.loop(21, 1), b = t.loop(23, 2);
  // Each one on its own disagrees grossly with the drifted estimate ...
  EXPECT_GT(t.residual(a), 30.0);
  EXPECT_GT(t.residual(b), 30.0);
  // ... but they agree with each other, in either order and direction.
  EXPECT_LT(t.distance(a, b), 1e-9);
  EXPECT_LT(t.distance(b, a), 1e-9);
  EXPECT_LT(t.distance(a, t.loop(2, 23)), 1e-9);
  EXPECT_LT(t.distance(t.loop(1, 21), b), 1e-9);
}

TEST_P(LoopConsistencyIn, FalseLoopClosureDisagreesWithATrueNeighbour) {
  DriftedTrajectory t(GetParam());
  const Edge a = t.loop(21, 1);
  Edge outlier = t.loop(23, 1);  // sharing a's older endpoint
  // A place 3 m away (perceptual aliasing), not the one the robot revisits.
  outlier.measurement = outlier.measurement * Pose::fromSE2(3.0, 0.0, 0.0);
  EXPECT_NEAR(t.distance(a, outlier), 3.0 / std::sqrt(0.02), 1e-6);
}

TEST_P(LoopConsistencyIn, DistanceIsWhitenedWithBothCovariances) {
  DriftedTrajectory t(GetParam());
  const Edge a = t.loop(21, 1);
  // Sharing a's older endpoint, so a's covariance reaches b's frame as it is.
  Edge b = t.loop(23, 1);
  b.measurement.translation.x() += 0.2;  // 0.2 m off; sigma 0.1 m in each loop closure
  EXPECT_NEAR(t.distance(a, b), 0.2 / std::sqrt(0.01 + 0.01), 1e-6);
}

// Stated covariances four times the real variance (the variance factor
// is a quarter): the same cycle error is twice as many sigma off.
TEST_P(LoopConsistencyIn, DistanceIsCalibratedByTheVarianceFactor) {
  DriftedTrajectory t(GetParam());
  const Edge a = t.loop(21, 1);
  Edge b = t.loop(23, 1);
  b.measurement.translation.x() += 0.2;
  const int n = GetParam() == 2 ? 3 : 6;
  const auto pose = [&t](int id) { return t.estimate[id]; };
  const StepCovariance exact = [n](int) { return Eigen::MatrixXd::Zero(n, n).eval(); };
  EXPECT_NEAR(cycleDistance(GetParam(), a, b, pose, exact, 0.25), 2.0 * t.distance(a, b), 1e-9);
}

// Loop closures across a gap in the odometry (a second session) cannot
// vouch for each other: the segment between their endpoints is not measured.
TEST_P(LoopConsistencyIn, NoConsistencyAcrossAGapInTheOdometry) {
  DriftedTrajectory t(GetParam());
  const int n = GetParam() == 2 ? 3 : 6;
  const StepCovariance gap_at_22 = [n](int p) {
    return p == 22 ? Eigen::MatrixXd() : Eigen::MatrixXd::Zero(n, n).eval();
  };
  const auto pose = [&t](int id) { return t.estimate[id]; };
  EXPECT_TRUE(std::isinf(cycleDistance(GetParam(), t.loop(21, 1), t.loop(23, 2), pose, gap_at_22)));
  EXPECT_LT(cycleDistance(GetParam(), t.loop(23, 1), t.loop(25, 2), pose, gap_at_22), 1e-9);
}

// The test is calibrated when the odometry is as uncertain as the loop
// closures (a car's scan-matched odometry): two true loop closures five
// steps apart at both ends, odometry and loop closures drawn at their stated
// covariance (anisotropic, correlated), curving path. Their squared cycle
// distance is chi-square with as many degrees of freedom as the tangent
// space: mean n, and 95 % below q(0.95). Without the segments' uncertainty
// the mean would be several times n and true neighbours would fail.
TEST_P(LoopConsistencyIn, SquaredDistanceOfTrueNeighboursIsChiSquare) {
  const int dim = GetParam(), n = dim == 2 ? 3 : 6;
  std::mt19937 random(3);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::MatrixXd sigma(n, n);
  if (dim == 2) {
    sigma << 4e-4, 1e-4, 2e-5, 1e-4, 2e-4, 0, 2e-5, 0, 1e-5;
  } else {
    const Eigen::VectorXd diagonal = (Eigen::VectorXd(6) << 4e-4, 2e-4, 1e-4, 1e-5, 2e-5, 1e-5).finished();
    sigma = diagonal.asDiagonal();
    sigma(0, 5) = sigma(5, 0) = 1e-5;
  }
  const Eigen::MatrixXd root = sigma.llt().matrixL();
  const auto perturbed = [&](const Pose& z) {
    Eigen::VectorXd d(n);
    for (int k = 0; k < n; ++k) d(k) = normal(random);
    d = root * d;
    const Pose small = dim == 2 ? Pose::fromSE2(d(0), d(1), d(2)) : Pose::fromXYZRPY(d(0), d(1), d(2), d(3), d(4), d(5));
    return z * small;
  };
  const Pose step = dim == 2 ? Pose::fromSE2(1.0, 0.0, 0.15) : Pose::fromXYZRPY(1.0, 0.1, 0.05, 0.03, -0.02, 0.15);
  const int poses = 40, trials = 2000;
  double sum = 0.0;
  int below = 0;
  const double q95 = dim == 2 ? 7.814727903 : 12.59158724;
  for (int trial = 0; trial < trials; ++trial) {
    Poses truth{Pose()}, estimate{Pose()};
    for (int p = 1; p < poses; ++p) {
      truth.push_back(truth.back() * step);
      estimate.push_back(estimate.back() * perturbed(step));  // dead reckoning
    }
    Edge a, b;
    a.from = 30, a.to = 3, b.from = 35, b.to = 8;
    a.measurement = perturbed(truth[a.from].inverse() * truth[a.to]);
    b.measurement = perturbed(truth[b.from].inverse() * truth[b.to]);
    a.information = b.information = sigma.inverse();
    const double d = cycleDistance(dim, a, b, [&estimate](int id) { return estimate[id]; },
                                   [&sigma](int) { return sigma; });
    sum += d * d;
    below += d * d < q95;
  }
  EXPECT_NEAR(sum / trials, n, 0.1 * n);
  EXPECT_NEAR(static_cast<double>(below) / trials, 0.95, 0.015);
}

INSTANTIATE_TEST_SUITE_P(Dimensions, LoopConsistencyIn, ::testing::Values(2, 3));

}  // namespace
}  // namespace core
}  // namespace agnc_pgo
