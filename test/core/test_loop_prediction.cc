// Whether the map explains a far loop closure better than chance: the
// likelihood ratio of loop_prediction.h, against values computed by hand.
#include "agnc_pgo/core/loop_prediction.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>
#include <cstdlib>

#include <gtest/gtest.h>

namespace agnc_pgo {
namespace core {
namespace {

TEST(LoopPrediction, ChanceVolumeIsTheWhitenedVolumeOfTheMapsRelativePoses) {
  // 100 m x 50 m, every heading; sigma 0.1 m and 0.01 rad: (1000 * 500)
  // translations and 2 pi / 0.01 rotations in whitened units.
  const Eigen::Matrix3d information = Eigen::Vector3d(100.0, 100.0, 1e4).asDiagonal();
  const double expected = std::log(1000.0 * 500.0 * 2.0 * M_PI / 0.01);
  EXPECT_NEAR(logChanceVolume(Eigen::Vector3d(100.0, 50.0, 2.0 * M_PI), information), expected, 1e-9);
  Eigen::Matrix<double, 6, 6> information3 = Eigen::Matrix<double, 6, 6>::Identity();
  Eigen::Matrix<double, 6, 1> extent3;
  extent3 << 10.0, 20.0, 30.0, 2.0, 3.0, 4.0;
  EXPECT_NEAR(logChanceVolume(extent3, information3), std::log(6000.0 * 24.0), 1e-9);
}

TEST(LoopPrediction, AnAxisTheMapDoesNotSpanCountsOneStandardDeviation) {
  // A straight corridor: no extent across it, yet a false loop closure can
  // still be off by its own noise there.
  const Eigen::Matrix3d information = Eigen::Vector3d(4.0, 4.0, 1.0).asDiagonal();
  EXPECT_NEAR(logChanceVolume(Eigen::Vector3d(30.0, 0.0, 0.0), information), std::log(4.0 * 30.0 * 0.5 * 1.0),
              1e-9);  // sqrt(det Omega) = 4
}

TEST(LoopPrediction, OddsAreTheLogOfTheGaussianDensityTimesTheVolume) {
  const Eigen::Vector3d r(3.0, 0.0, 4.0);
  const Eigen::Matrix3d s = Eigen::Vector3d(9.0, 1.0, 4.0).asDiagonal();
  // r^T S^-1 r = 1 + 0 + 4, log det S = log 36.
  const double expected = 20.0 - 0.5 * (5.0 + std::log(36.0) + 3.0 * std::log(2.0 * M_PI));
  EXPECT_NEAR(logPredictionOdds(r, s, 20.0), expected, 1e-12);
}

TEST(LoopPrediction, AWideUncertaintyExplainsNothingBetterThanChance) {
  // The same small residual: a map that knows where the endpoints are
  // explains it; one whose endpoints could be anywhere does not, although
  // the residual is then well inside its covariance.
  const Eigen::Vector3d r(20.0, -10.0, 5.0);
  const double log_volume = 15.0;
  EXPECT_GT(logPredictionOdds(r, 100.0 * Eigen::Matrix3d::Identity(), log_volume), 0.0);
  const Eigen::Matrix3d wide = 1e8 * Eigen::Matrix3d::Identity();
  EXPECT_LT(r.dot(wide.inverse() * r), 1e-4);
  EXPECT_LT(logPredictionOdds(r, wide, log_volume), 0.0);
}

TEST(LoopPrediction, TheKthJudgementMustBeatOddsOfK) {
  EXPECT_EQ(repeatedJudgementLogOdds(1), 0.0);  // the first keeps even odds
  EXPECT_DOUBLE_EQ(repeatedJudgementLogOdds(2), std::log(2.0));
  EXPECT_DOUBLE_EQ(repeatedJudgementLogOdds(19), std::log(19.0));
  EXPECT_THROW(repeatedJudgementLogOdds(0), std::invalid_argument);
}

TEST(LoopPrediction, UnderChanceTheKthBarIsBeatenAtMostOnceInK) {
  // What makes log k the bar of the k-th judgement: where the residual is
  // chance (uniform over the map's volume), the prediction's likelihood
  // ratio has mean 1, so it exceeds k on at most 1/k of the volume. 3-D
  // residuals on a grid over a cube of side 40 (log V = 3 log 40), a
  // prediction of standard deviation 2 at the centre.
  const double side = 40.0, log_volume = 3.0 * std::log(side);
  const Eigen::Matrix3d s = 4.0 * Eigen::Matrix3d::Identity();
  const int n = 60;
  for (int k : {1, 2, 3, 10, 100}) {
    int beaten = 0;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        for (int l = 0; l < n; ++l) {
          const Eigen::Vector3d r(side * ((i + 0.5) / n - 0.5), side * ((j + 0.5) / n - 0.5),
                                  side * ((l + 0.5) / n - 0.5));
          if (logPredictionOdds(r, s, log_volume - repeatedJudgementLogOdds(k)) > 0.0) ++beaten;
        }
    const double fraction = static_cast<double>(beaten) / (n * n * n);
    EXPECT_LE(fraction, 1.0 / k) << "k = " << k;
    EXPECT_GT(fraction, 0.0) << "k = " << k;  // the bar is not out of reach
  }
}

TEST(LoopPrediction, ANonFiniteOrSingularCovarianceExplainsNothing) {
  const Eigen::Vector3d r(1.0, 1.0, 1.0);
  EXPECT_EQ(logPredictionOdds(r, Eigen::Matrix3d::Constant(INFINITY), 10.0), -INFINITY);
  EXPECT_EQ(logPredictionOdds(r, Eigen::Matrix3d::Zero(), 10.0), -INFINITY);
}

// The bound the map test decides with before factorising: for every
// covariance between floor * I and the ceiling, the odds are at most it.
TEST(LoopPrediction, OddsBoundHoldsForEveryCovarianceBetweenFloorAndCeiling) {
  std::srand(7);
  const double floor = 0.3, log_volume = 12.0;
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Vector3d r = 5.0 * Eigen::Vector3d::Random();
    const Eigen::Matrix3d a = Eigen::Matrix3d::Random(), b = Eigen::Matrix3d::Random();
    const Eigen::Matrix3d map = floor * (Eigen::Matrix3d::Identity() + a * a.transpose());
    const Eigen::Matrix3d ceiling = map + b * b.transpose();
    const double bound = logPredictionOddsBound(r, ceiling, floor, log_volume);
    EXPECT_GE(bound, logPredictionOdds(r, map, log_volume) - 1e-9);
    EXPECT_GE(bound, logPredictionOdds(r, ceiling, log_volume) - 1e-9);
  }
  // Tight at S = floor * I = ceiling.
  const Eigen::Vector3d r(1.0, 2.0, 0.5);
  EXPECT_NEAR(logPredictionOddsBound(r, floor * Eigen::Matrix3d::Identity(), floor, log_volume),
              logPredictionOdds(r, floor * Eigen::Matrix3d::Identity(), log_volume), 1e-12);
  // An unknown ceiling bounds nothing.
  EXPECT_EQ(logPredictionOddsBound(r, Eigen::Matrix3d::Constant(INFINITY), floor, log_volume), INFINITY);
}

TEST(LoopPrediction, ExtentIsPerAxisAndHeadingsLieOnTheCircle) {
  // Headings 170, -170 and 150 degrees: the arc through 180 holds them (40
  // degrees), not the 340 degrees from -170 to 170.
  const double deg = M_PI / 180.0;
  Poses poses{Pose::fromSE2(1.0, -2.0, 170 * deg), Pose::fromSE2(4.0, 3.0, -170 * deg),
              Pose::fromSE2(-1.0, 0.0, 150 * deg)};
  EXPECT_TRUE(mapExtent(2, poses).isApprox(Eigen::Vector3d(5.0, 5.0, 40 * deg)));
  EXPECT_EQ(mapExtent(2, Poses()).size(), 3);
  EXPECT_NEAR(circularExtent({0.0, M_PI / 2, M_PI, -M_PI / 2}), 1.5 * M_PI, 1e-12);
}

TEST(LoopPrediction, CircularExtentIsTheCircleLessItsLargestGap) {
  // Against the definition: sorted, the largest gap between neighbours
  // (the one across +-pi included), for clustered, spread, repeated and
  // evenly spaced angles.
  const auto by_sorting = [](std::vector<double> angles) {
    for (double& a : angles) a = std::remainder(a, 2.0 * M_PI);
    std::sort(angles.begin(), angles.end());
    double gap = angles.front() + 2.0 * M_PI - angles.back();
    for (size_t k = 1; k < angles.size(); ++k) gap = std::max(gap, angles[k] - angles[k - 1]);
    return 2.0 * M_PI - gap;
  };
  std::mt19937 random(7);
  for (int trial = 0; trial < 200; ++trial) {
    const int n = 1 + trial % 40;
    const double centre = std::uniform_real_distribution<double>(-M_PI, M_PI)(random);
    const double spread = std::uniform_real_distribution<double>(0.0, 4.0)(random);
    std::normal_distribution<double> around(centre, spread);
    std::vector<double> angles;
    for (int i = 0; i < n; ++i) angles.push_back(trial % 7 == 0 && i % 2 ? angles.back() : around(random));
    EXPECT_NEAR(circularExtent(angles), by_sorting(angles), 1e-12) << "trial " << trial;
  }
  std::vector<double> even;
  for (int i = 0; i < 12; ++i) even.push_back(i * M_PI / 6);
  EXPECT_NEAR(circularExtent(even), 11 * M_PI / 6, 1e-12);
  EXPECT_EQ(circularExtent({0.3}), 0.0);
  EXPECT_EQ(circularExtent({0.3, 0.3}), 0.0);
}

TEST(LoopPrediction, AGroundVehicleSpansYawButHardlyRollAndPitch) {
  Poses poses;
  for (int i = 0; i < 36; ++i)
    poses.push_back(Pose::fromXYZRPY(i, 0.5 * i, 0.01 * (i % 3), 0.02 * (i % 2), -0.01 * (i % 4), i * 10.0 * M_PI / 180));
  const Eigen::VectorXd extent = mapExtent(3, poses);
  ASSERT_EQ(extent.size(), 6);
  EXPECT_NEAR(extent(0), 35.0, 1e-9);
  EXPECT_NEAR(extent(2), 0.02, 1e-9);
  EXPECT_NEAR(extent(3), 0.02, 1e-9);   // roll
  EXPECT_NEAR(extent(4), 0.03, 1e-9);   // pitch
  EXPECT_NEAR(extent(5), 350.0 * M_PI / 180, 1e-9);  // yaw
}

}  // namespace
}  // namespace core
}  // namespace agnc_pgo
