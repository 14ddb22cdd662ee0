// Tests for loop-closure classification counts, ATE, RPE and the TUM writer.
#include "agnc_pgo/eval/metrics.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/Geometry>

namespace agnc_pgo {
namespace core {
namespace {

// Built directly (not via Pose::fromSE2) so these tests only depend on metrics.
Pose planarPose(double x, double y, double yaw) {
  Pose pose;
  pose.translation = Eigen::Vector3d(x, y, 0.0);
  pose.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  return pose;
}

Pose spatialPose(const Eigen::Vector3d& t, const Eigen::Quaterniond& q) {
  Pose pose;
  pose.translation = t;
  pose.rotation = q.normalized();
  return pose;
}

// T * pose with T = (R, t), written out so the test does not rely on Pose::operator*.
Pose transformed(const Eigen::Quaterniond& R, const Eigen::Vector3d& t, const Pose& pose) {
  return spatialPose(R * pose.translation + t, R * pose.rotation);
}

Poses randomPlanarTrajectory(int n, std::mt19937_64* rng) {
  std::uniform_real_distribution<double> coord(-20.0, 20.0);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI);
  Poses poses;
  for (int k = 0; k < n; ++k) poses.push_back(planarPose(coord(*rng), coord(*rng), angle(*rng)));
  return poses;
}

Poses randomSpatialTrajectory(int n, std::mt19937_64* rng) {
  std::uniform_real_distribution<double> coord(-20.0, 20.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  Poses poses;
  for (int k = 0; k < n; ++k) {
    const Eigen::Quaterniond q(gauss(*rng), gauss(*rng), gauss(*rng), gauss(*rng));
    poses.push_back(spatialPose(Eigen::Vector3d(coord(*rng), coord(*rng), coord(*rng)), q));
  }
  return poses;
}

// ----------------------------------------------------------- classification

TEST(Classify, CountsEachCategory) {
  //                         true  true   out    out   true  out   true
  const std::vector<bool> is_outlier = {false, false, true, true, false, true, false};
  const std::vector<bool> kept = {true, false, true, false, true, false, false};
  const ClassificationCounts counts = classify(is_outlier, kept);
  EXPECT_EQ(counts.true_positive, 2);
  EXPECT_EQ(counts.false_positive, 1);
  EXPECT_EQ(counts.false_negative, 2);
  EXPECT_EQ(counts.true_negative, 2);
  EXPECT_DOUBLE_EQ(counts.precision(), 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(counts.recall(), 2.0 / 4.0);
}

TEST(Classify, PerfectClassifier) {
  const std::vector<bool> is_outlier = {false, true, false, true};
  const std::vector<bool> kept = {true, false, true, false};
  const ClassificationCounts counts = classify(is_outlier, kept);
  EXPECT_EQ(counts.true_positive, 2);
  EXPECT_EQ(counts.true_negative, 2);
  EXPECT_EQ(counts.false_positive, 0);
  EXPECT_EQ(counts.false_negative, 0);
  EXPECT_DOUBLE_EQ(counts.precision(), 1.0);
  EXPECT_DOUBLE_EQ(counts.recall(), 1.0);
}

TEST(Classify, KeepEverything) {
  const std::vector<bool> is_outlier = {false, true, true, true};
  const std::vector<bool> kept(4, true);
  const ClassificationCounts counts = classify(is_outlier, kept);
  EXPECT_DOUBLE_EQ(counts.precision(), 0.25);
  EXPECT_DOUBLE_EQ(counts.recall(), 1.0);
}

TEST(Classify, NothingKeptHasPrecisionOne) {
  const std::vector<bool> is_outlier = {false, true, false};
  const std::vector<bool> kept(3, false);
  const ClassificationCounts counts = classify(is_outlier, kept);
  EXPECT_EQ(counts.true_positive, 0);
  EXPECT_EQ(counts.false_positive, 0);
  EXPECT_EQ(counts.false_negative, 2);
  EXPECT_EQ(counts.true_negative, 1);
  EXPECT_DOUBLE_EQ(counts.precision(), 1.0);
  EXPECT_DOUBLE_EQ(counts.recall(), 0.0);
}

TEST(Classify, NoTrueLoopsHasRecallOne) {
  const std::vector<bool> is_outlier = {true, true};
  const std::vector<bool> kept = {true, false};
  const ClassificationCounts counts = classify(is_outlier, kept);
  EXPECT_DOUBLE_EQ(counts.recall(), 1.0);
  EXPECT_DOUBLE_EQ(counts.precision(), 0.0);
}

TEST(Classify, EmptyInput) {
  const ClassificationCounts counts = classify({}, {});
  EXPECT_EQ(counts.true_positive + counts.false_positive + counts.false_negative + counts.true_negative, 0);
  EXPECT_DOUBLE_EQ(counts.precision(), 1.0);
  EXPECT_DOUBLE_EQ(counts.recall(), 1.0);
}

TEST(Classify, LengthMismatchThrows) {
  EXPECT_THROW(classify({true, false}, {true}), std::invalid_argument);
  EXPECT_THROW(classify({}, {false}), std::invalid_argument);
}

// ----------------------------------------------------------------------- ATE

TEST(AbsoluteTrajectoryError, ZeroForRigidlyMovedPlanarCopy) {
  std::mt19937_64 rng(7);
  const Poses reference = randomPlanarTrajectory(50, &rng);
  const Eigen::Quaterniond R(Eigen::AngleAxisd(1.234, Eigen::Vector3d::UnitZ()));
  const Eigen::Vector3d t(5.0, -3.0, 0.0);
  Poses estimate;
  for (const Pose& pose : reference) estimate.push_back(transformed(R, t, pose));
  EXPECT_NEAR(absoluteTrajectoryError(estimate, reference, 2), 0.0, 1e-9);
}

TEST(AbsoluteTrajectoryError, PlanarIgnoresZ) {
  std::mt19937_64 rng(8);
  const Poses reference = randomPlanarTrajectory(20, &rng);
  Poses estimate = reference;
  for (std::size_t k = 0; k < estimate.size(); ++k) estimate[k].translation.z() = 3.0 * k;
  EXPECT_NEAR(absoluteTrajectoryError(estimate, reference, 2), 0.0, 1e-9);
  // In 3D the same z offsets are a real error.
  EXPECT_GT(absoluteTrajectoryError(estimate, reference, 3), 1.0);
}

TEST(AbsoluteTrajectoryError, ZeroForRigidlyMovedSpatialCopy) {
  std::mt19937_64 rng(11);
  const Poses reference = randomSpatialTrajectory(60, &rng);
  const Eigen::Quaterniond R = Eigen::Quaterniond(0.3, -0.5, 0.7, 0.2).normalized();
  const Eigen::Vector3d t(-4.0, 2.5, 9.0);
  Poses estimate;
  for (const Pose& pose : reference) estimate.push_back(transformed(R, t, pose));
  EXPECT_NEAR(absoluteTrajectoryError(estimate, reference, 3), 0.0, 1e-9);
}

// A square scaled by 2 about its centre: the best rigid alignment is the
// identity (the cross-covariance is symmetric positive definite), so every
// corner is off by |p| = sqrt(2) and the RMSE is sqrt(2) -- wherever the copy
// is moved rigidly. Without scaling, Umeyama must not shrink it back.
TEST(AbsoluteTrajectoryError, KnownValueForScaledSquare) {
  const double corners[4][2] = {{1, 1}, {-1, 1}, {-1, -1}, {1, -1}};
  Poses reference;
  Poses estimate;
  const Eigen::Quaterniond R(Eigen::AngleAxisd(-0.7, Eigen::Vector3d::UnitZ()));
  const Eigen::Vector3d t(10.0, 4.0, 0.0);
  for (const auto& c : corners) {
    reference.push_back(planarPose(c[0], c[1], 0.0));
    estimate.push_back(transformed(R, t, planarPose(2.0 * c[0], 2.0 * c[1], 0.3)));
  }
  EXPECT_NEAR(absoluteTrajectoryError(estimate, reference, 2), std::sqrt(2.0), 1e-9);
}

// Cube corners scaled by 1.5: each is off by 0.5 * sqrt(3).
TEST(AbsoluteTrajectoryError, KnownValueForScaledCube) {
  Poses reference;
  Poses estimate;
  const Eigen::Quaterniond R = Eigen::Quaterniond(0.9, 0.1, -0.3, 0.2).normalized();
  const Eigen::Vector3d t(1.0, -2.0, 3.0);
  for (int bits = 0; bits < 8; ++bits) {
    const Eigen::Vector3d p((bits & 1) ? 1 : -1, (bits & 2) ? 1 : -1, (bits & 4) ? 1 : -1);
    reference.push_back(spatialPose(p, Eigen::Quaterniond::Identity()));
    estimate.push_back(transformed(R, t, spatialPose(1.5 * p, Eigen::Quaterniond::Identity())));
  }
  EXPECT_NEAR(absoluteTrajectoryError(estimate, reference, 3), 0.5 * std::sqrt(3.0), 1e-9);
}

// A constant position offset is a rigid motion, so alignment removes it.
TEST(AbsoluteTrajectoryError, PureOffsetIsRemoved) {
  Poses reference = {planarPose(0, 0, 0), planarPose(1, 0, 0), planarPose(3, 2, 0)};
  Poses estimate;
  for (const Pose& pose : reference) estimate.push_back(planarPose(pose.translation.x() + 0.4,
                                                                    pose.translation.y() - 7.0, 0.0));
  EXPECT_NEAR(absoluteTrajectoryError(estimate, reference, 2), 0.0, 1e-9);
}

TEST(AbsoluteTrajectoryError, RejectsBadInput) {
  const Poses two = {planarPose(0, 0, 0), planarPose(1, 0, 0)};
  const Poses three = {planarPose(0, 0, 0), planarPose(1, 0, 0), planarPose(2, 0, 0)};
  EXPECT_THROW(absoluteTrajectoryError(two, three, 2), std::invalid_argument);
  EXPECT_THROW(absoluteTrajectoryError(two, two, 4), std::invalid_argument);
  EXPECT_THROW(absoluteTrajectoryError(Poses(), Poses(), 2), std::invalid_argument);
}

// ----------------------------------------------------------------------- RPE

TEST(RelativePoseError, ZeroForRigidlyMovedCopy) {
  std::mt19937_64 rng(3);
  const Poses reference = randomSpatialTrajectory(40, &rng);
  const Eigen::Quaterniond R = Eigen::Quaterniond(-0.2, 0.4, 0.1, 0.8).normalized();
  const Eigen::Vector3d t(3.0, 1.0, -6.0);
  Poses estimate;
  for (const Pose& pose : reference) estimate.push_back(transformed(R, t, pose));
  EXPECT_NEAR(relativePoseError(estimate, reference), 0.0, 1e-9);
}

// Reference: three poses along x with unit steps. Estimate: the second pose
// is rotated by 90 deg about z, the third sits at (1, 2) -- i.e. two metres
// ahead in the second pose's frame. Step errors: 0 and |(2,0)-(1,0)| = 1,
// so RMSE = sqrt((0 + 1) / 2).
TEST(RelativePoseError, KnownValueForHandMadeCase) {
  const Poses reference = {planarPose(0, 0, 0), planarPose(1, 0, 0), planarPose(2, 0, 0)};
  const Poses estimate = {planarPose(0, 0, 0), planarPose(1, 0, M_PI / 2), planarPose(1, 2, M_PI / 2)};
  EXPECT_NEAR(relativePoseError(estimate, reference), std::sqrt(0.5), 1e-12);
}

// Translation-only stretch: steps 1 vs 1 and 1 vs 1.5 -> RMSE sqrt(0.25 / 2).
TEST(RelativePoseError, KnownValueForStretchedStep) {
  const Poses reference = {planarPose(0, 0, 0), planarPose(1, 0, 0), planarPose(2, 0, 0)};
  const Poses estimate = {planarPose(0, 0, 0), planarPose(1, 0, 0), planarPose(2.5, 0, 0)};
  EXPECT_NEAR(relativePoseError(estimate, reference), std::sqrt(0.125), 1e-12);
}

TEST(RelativePoseError, DegenerateAndBadInput) {
  const Poses one = {planarPose(0, 0, 0)};
  const Poses two = {planarPose(0, 0, 0), planarPose(1, 0, 0)};
  EXPECT_DOUBLE_EQ(relativePoseError(one, one), 0.0);
  EXPECT_THROW(relativePoseError(one, two), std::invalid_argument);
}

// ----------------------------------------------------------------------- TUM

std::vector<std::vector<double>> readNumbers(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::vector<double>> rows;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::vector<double> row;
    double value;
    while (fields >> value) row.push_back(value);
    rows.push_back(row);
  }
  return rows;
}

TEST(WriteTumTrajectory, RoundTripsEveryNumber) {
  std::mt19937_64 rng(5);
  const Poses poses = randomSpatialTrajectory(25, &rng);
  const std::string path = testing::TempDir() + "agnc_pgo_test_metrics_tum.txt";
  writeTumTrajectory(poses, path);
  const auto rows = readNumbers(path);
  ASSERT_EQ(rows.size(), poses.size());
  for (std::size_t k = 0; k < poses.size(); ++k) {
    ASSERT_EQ(rows[k].size(), 8u) << "line " << k;
    EXPECT_EQ(rows[k][0], static_cast<double>(k));
    EXPECT_EQ(rows[k][1], poses[k].translation.x());
    EXPECT_EQ(rows[k][2], poses[k].translation.y());
    EXPECT_EQ(rows[k][3], poses[k].translation.z());
    EXPECT_EQ(rows[k][4], poses[k].rotation.x());
    EXPECT_EQ(rows[k][5], poses[k].rotation.y());
    EXPECT_EQ(rows[k][6], poses[k].rotation.z());
    EXPECT_EQ(rows[k][7], poses[k].rotation.w());
  }
  std::remove(path.c_str());
}

TEST(WriteTumTrajectory, UsesGivenStamps) {
  const Poses poses = {planarPose(0, 0, 0), planarPose(1, 2, 0.5), planarPose(3, 4, -1)};
  const std::vector<double> stamps = {1.5e9, 1.5e9 + 0.1, 1.5e9 + 0.2};
  const std::string path = testing::TempDir() + "agnc_pgo_test_metrics_tum_stamps.txt";
  writeTumTrajectory(poses, path, stamps);
  const auto rows = readNumbers(path);
  ASSERT_EQ(rows.size(), 3u);
  for (std::size_t k = 0; k < rows.size(); ++k) EXPECT_EQ(rows[k][0], stamps[k]);
  std::remove(path.c_str());
}

TEST(WriteTumTrajectory, RejectsBadInput) {
  const Poses poses = {planarPose(0, 0, 0), planarPose(1, 0, 0)};
  const std::string path = testing::TempDir() + "agnc_pgo_test_metrics_tum_bad.txt";
  EXPECT_THROW(writeTumTrajectory(poses, path, {0.0}), std::invalid_argument);
  EXPECT_THROW(writeTumTrajectory(poses, "/nonexistent_dir_agnc_pgo/traj.txt"), std::runtime_error);
  std::remove(path.c_str());
}

}  // namespace
}  // namespace core
}  // namespace agnc_pgo
