// Message <-> core conversions: poses (2D projection, quaternion checks),
// REP 103 covariance <-> g2o-ordered information (2D and 3D), and the
// stamp matcher / keyframe selector that sit next to them.
#include <cmath>

#include <gtest/gtest.h>

#include "agnc_pgo/ros/conversions.h"
#include "agnc_pgo/ros/keyframe_selector.h"
#include "agnc_pgo/ros/loop_closure_matcher.h"

using namespace agnc_pgo;
using namespace agnc_pgo::ros_backend;

namespace {

RosCovariance zeros() {
  RosCovariance c;
  c.fill(0.0);
  return c;
}

// A random symmetric positive-definite 6x6 covariance in REP 103 order.
Eigen::MatrixXd randomSpd(int n, int seed) {
  std::srand(seed);
  const Eigen::MatrixXd a = Eigen::MatrixXd::Random(n, n);
  return a * a.transpose() + 0.5 * Eigen::MatrixXd::Identity(n, n);
}

RosCovariance toRos(const Eigen::MatrixXd& m) {
  RosCovariance c = zeros();
  for (int r = 0; r < 6; ++r)
    for (int col = 0; col < 6; ++col) c[6 * r + col] = m(r, col);
  return c;
}

}  // namespace

TEST(Conversions, PoseRoundTrip) {
  core::Pose p = core::Pose::fromXYZRPY(1, -2, 3, 0.1, -0.2, 0.3);
  const core::Pose q = fromMsg(toMsg(p));
  EXPECT_LT((p.translation - q.translation).norm(), 1e-15);
  EXPECT_NEAR(std::abs(p.rotation.dot(q.rotation)), 1.0, 1e-15);
}

TEST(Conversions, QuaternionIsNormalised) {
  geometry_msgs::Pose m;
  m.orientation.w = 1.05;  // slightly off: accepted and normalised
  EXPECT_EQ(checkPose(m), "");
  EXPECT_NEAR(fromMsg(m).rotation.norm(), 1.0, 1e-15);
}

TEST(Conversions, RejectsBadPoses) {
  geometry_msgs::Pose m;
  m.orientation.w = 1.0;
  m.position.x = NAN;
  EXPECT_NE(checkPose(m).find("NaN"), std::string::npos);
  m.position.x = 0;
  m.orientation.w = 0;
  EXPECT_EQ(checkPose(m), "zero quaternion");
  m.orientation.w = INFINITY;
  EXPECT_NE(checkPose(m).find("NaN/Inf"), std::string::npos);
}

TEST(Conversions, PlanarProjectionKeepsXYYaw) {
  const core::Pose p = core::Pose::fromXYZRPY(1, 2, 0.5, 0.0, 0.0, 2.5);
  const core::Pose q = toDimension(p, 2);
  EXPECT_DOUBLE_EQ(q.translation.x(), 1);
  EXPECT_DOUBLE_EQ(q.translation.y(), 2);
  EXPECT_DOUBLE_EQ(q.translation.z(), 0);
  EXPECT_NEAR(q.yaw(), 2.5, 1e-12);
  EXPECT_LT((toDimension(p, 3).translation - p.translation).norm(), 1e-15);
}

TEST(Conversions, Covariance2DUsesXYYawBlock) {
  // Distinct entries in the x y yaw block; junk elsewhere must be ignored.
  RosCovariance c = zeros();
  const int idx[3] = {0, 1, 5};
  Eigen::Matrix3d sigma;
  sigma << 0.04, 0.01, 0.002, 0.01, 0.09, -0.003, 0.002, -0.003, 0.01;
  for (int r = 0; r < 3; ++r)
    for (int col = 0; col < 3; ++col) c[6 * idx[r] + idx[col]] = sigma(r, col);
  c[6 * 2 + 2] = 1e6;  // z variance: not used in 2D
  c[6 * 3 + 4] = 7.0;  // roll-pitch coupling (would make 6x6 non-PD)
  const Eigen::MatrixXd info = informationFromCovariance(c, 2);
  ASSERT_EQ(info.rows(), 3);
  EXPECT_LT((info - Eigen::Matrix3d(sigma.inverse())).norm(), 1e-9);
  // And back: the block lands at (x y yaw), zeros elsewhere.
  const RosCovariance back = covarianceFromInformation(info, 2);
  for (int r = 0; r < 3; ++r)
    for (int col = 0; col < 3; ++col) EXPECT_NEAR(back[6 * idx[r] + idx[col]], sigma(r, col), 1e-12);
  EXPECT_EQ(back[6 * 2 + 2], 0.0);
  EXPECT_EQ(back[6 * 3 + 4], 0.0);
}

TEST(Conversions, Covariance3DOrderIsXYZRollPitchYaw) {
  // A diagonal covariance with distinct variances: information (g2o order
  // x y z rx ry rz) must have 1/var in the same slots.
  RosCovariance c = zeros();
  const double var[6] = {1, 2, 3, 4, 5, 6};  // x y z roll pitch yaw
  for (int i = 0; i < 6; ++i) c[7 * i] = var[i];
  const Eigen::MatrixXd info = informationFromCovariance(c, 3);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(info(i, i), 1.0 / var[i], 1e-15);
  // A full covariance round-trips exactly through the information.
  const Eigen::MatrixXd sigma = randomSpd(6, 3);
  const RosCovariance full = toRos(sigma);
  const RosCovariance back = covarianceFromInformation(informationFromCovariance(full, 3), 3);
  for (int i = 0; i < 36; ++i) EXPECT_NEAR(back[i], full[i], 1e-9 * sigma.norm());
  // The roll-yaw coupling lands at (rx, rz) of the information's inverse.
  EXPECT_NEAR(covarianceOf(informationFromCovariance(full, 3))(3, 5), sigma(3, 5), 1e-9);
}

TEST(Conversions, RejectsNonPositiveDefiniteCovariances) {
  RosCovariance c = zeros();
  for (int i = 0; i < 6; ++i) c[7 * i] = 1.0;
  c[7 * 5] = -1.0;  // negative yaw variance
  EXPECT_THROW(informationFromCovariance(c, 3), std::invalid_argument);
  EXPECT_THROW(informationFromCovariance(c, 2), std::invalid_argument);
  c[7 * 5] = 0.0;  // singular
  EXPECT_THROW(informationFromCovariance(c, 2), std::invalid_argument);
  c[7 * 5] = 1.0;
  c[1] = 5.0;  // not symmetric
  EXPECT_THROW(informationFromCovariance(c, 2), std::invalid_argument);
  c[1] = c[6] = 5.0;  // symmetric but indefinite
  EXPECT_THROW(informationFromCovariance(c, 2), std::invalid_argument);
  c[1] = NAN;
  EXPECT_THROW(informationFromCovariance(c, 3), std::invalid_argument);
  EXPECT_TRUE(isZero(zeros()));
}

TEST(Conversions, SigmasToInformation) {
  const Sigmas s{{0.1, 0.2, 0.3, 0.4, 0.5, 0.6}};
  const Eigen::MatrixXd i2 = informationFromSigmas(s, 2);
  EXPECT_NEAR(i2(0, 0), 100, 1e-9);
  EXPECT_NEAR(i2(1, 1), 25, 1e-9);
  EXPECT_NEAR(i2(2, 2), 1 / 0.36, 1e-9);  // yaw
  const Eigen::MatrixXd i3 = informationFromSigmas(s, 3);
  EXPECT_NEAR(i3(3, 3), 1 / 0.16, 1e-9);  // roll = rx
  EXPECT_NEAR(i3(5, 5), 1 / 0.36, 1e-9);  // yaw = rz
}

TEST(LoopClosureMatcher, NearestWithinTolerance) {
  LoopClosureMatcher m(0.01);
  EXPECT_EQ(m.match(ros::Time(5.0)).status, LoopClosureMatcher::Status::kNotYet);
  m.add(ros::Time(1.0));
  m.add(ros::Time(1.1));
  m.add(ros::Time(1.2));
  EXPECT_EQ(m.match(ros::Time(1.104)).id, 1);
  EXPECT_EQ(m.match(ros::Time(1.195)).id, 2);
  EXPECT_EQ(m.match(ros::Time(0.995)).id, 0);
  EXPECT_EQ(m.match(ros::Time(1.15)).status, LoopClosureMatcher::Status::kUnknown);
  EXPECT_EQ(m.match(ros::Time(0.5)).status, LoopClosureMatcher::Status::kUnknown);
  EXPECT_EQ(m.match(ros::Time(1.3)).status, LoopClosureMatcher::Status::kNotYet);
  EXPECT_THROW(m.add(ros::Time(1.2)), std::invalid_argument);
}

TEST(KeyframeSelector, ThresholdsAndStampOrder) {
  KeyframeParameters p;
  p.translation = 1.0;
  p.rotation = 0.5;
  KeyframeSelector s(p);
  using D = KeyframeSelector::Decision;
  EXPECT_EQ(s.consider(ros::Time(1), core::Pose::fromSE2(0, 0, 0)), D::kKeyframe);
  EXPECT_EQ(s.consider(ros::Time(2), core::Pose::fromSE2(0.5, 0, 0)), D::kSkip);
  EXPECT_EQ(s.consider(ros::Time(2), core::Pose::fromSE2(0.6, 0, 0)), D::kStampNotIncreasing);
  EXPECT_EQ(s.consider(ros::Time(1.5), core::Pose::fromSE2(0.6, 0, 0)), D::kStampNotIncreasing);
  EXPECT_EQ(s.consider(ros::Time(3), core::Pose::fromSE2(1.0, 0, 0)), D::kKeyframe);
  EXPECT_EQ(s.consider(ros::Time(4), core::Pose::fromSE2(1.0, 0, 0.6)), D::kKeyframe);
  KeyframeSelector every(KeyframeParameters{});
  EXPECT_EQ(every.consider(ros::Time(1), core::Pose()), D::kKeyframe);
  EXPECT_EQ(every.consider(ros::Time(2), core::Pose()), D::kKeyframe);
}
