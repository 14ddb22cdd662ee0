// Pairwise consistency of neighbouring loop closures: true loop closures
// agree with each other through the local trajectory however much the map
// has drifted; a false one does not.
#include "agnc_pgo/core/loop_consistency.h"

#include <cmath>
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
    return cycleDistance(dimension, a, b, [this](int id) { return estimate[id]; });
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
  Edge outlier = t.loop(23, 2);
  // A place 3 m away (perceptual aliasing), not the one the robot revisits.
  outlier.measurement = outlier.measurement * Pose::fromSE2(3.0, 0.0, 0.0);
  EXPECT_NEAR(t.distance(a, outlier), 3.0 / std::sqrt(0.02), 1e-6);
}

TEST_P(LoopConsistencyIn, DistanceIsWhitenedWithBothCovariances) {
  DriftedTrajectory t(GetParam());
  const Edge a = t.loop(21, 1);
  Edge b = t.loop(23, 2);
  b.measurement.translation.x() += 0.2;  // 0.2 m off; sigma 0.1 m in each loop closure
  EXPECT_NEAR(t.distance(a, b), 0.2 / std::sqrt(0.01 + 0.01), 1e-6);
}

INSTANTIATE_TEST_SUITE_P(Dimensions, LoopConsistencyIn, ::testing::Values(2, 3));

}  // namespace
}  // namespace core
}  // namespace agnc_pgo
