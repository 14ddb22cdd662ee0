#include "agnc_pgo/core/pose.h"

#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace agnc_pgo {
namespace core {
namespace {

constexpr double kTol = 1e-12;

Eigen::Matrix4d homogeneous(const Pose& p) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = p.rotation.toRotationMatrix();
  m.topRightCorner<3, 1>() = p.translation;
  return m;
}

void expectPoseNear(const Pose& expected, const Pose& actual, double tol = kTol) {
  EXPECT_TRUE(expected.translation.isApprox(actual.translation, tol) ||
              (expected.translation - actual.translation).norm() < tol)
      << expected.translation.transpose() << " vs " << actual.translation.transpose();
  // q and -q are the same rotation: compare rotation matrices.
  const Eigen::Matrix3d difference =
      expected.rotation.toRotationMatrix() - actual.rotation.toRotationMatrix();
  EXPECT_LT(difference.norm(), tol);
}

TEST(Pose, CompositionMatchesHomogeneousMatrices) {
  const Pose a = Pose::fromXYZRPY(1.0, -2.0, 0.5, 0.3, -0.7, 2.1);
  const Pose b = Pose::fromXYZRPY(-0.4, 0.9, 3.0, -1.2, 0.2, -2.8);
  const Eigen::Matrix4d expected = homogeneous(a) * homogeneous(b);
  EXPECT_LT((homogeneous(a * b) - expected).norm(), kTol);
  EXPECT_LT((homogeneous(a.inverse()) - homogeneous(a).inverse()).norm(), kTol);
}

TEST(Pose, InverseAndCompositionRoundTrip) {
  const Pose a = Pose::fromXYZRPY(1.0, -2.0, 0.5, 0.3, -0.7, 2.1);
  const Pose b = Pose::fromXYZRPY(-0.4, 0.9, 3.0, -1.2, 0.2, -2.8);
  expectPoseNear(Pose::identity(), a * a.inverse());
  expectPoseNear(Pose::identity(), a.inverse() * a);
  expectPoseNear(a, a.inverse().inverse());
  expectPoseNear(a, (a * b) * b.inverse());
  expectPoseNear(b, a.inverse() * (a * b));
  EXPECT_NEAR((a * b).rotation.norm(), 1.0, 1e-15);

  const Pose p = Pose::fromSE2(3.0, -1.0, 2.5);
  const Pose q = Pose::fromSE2(-0.5, 2.0, -1.9);
  const Pose pq = p * q;
  EXPECT_NEAR(pq.yaw(), wrapAngle(2.5 - 1.9), kTol);
  EXPECT_NEAR(pq.translation.x(), 3.0 + std::cos(2.5) * -0.5 - std::sin(2.5) * 2.0, kTol);
  EXPECT_NEAR(pq.translation.y(), -1.0 + std::sin(2.5) * -0.5 + std::cos(2.5) * 2.0, kTol);
  EXPECT_EQ(pq.translation.z(), 0.0);
}

TEST(Pose, FromXYZRPYMatchesExplicitRotationMatrix) {
  const double rx = 0.3, ry = -0.7, rz = 2.1;
  Eigen::Matrix3d rot_x, rot_y, rot_z;
  rot_x << 1, 0, 0, 0, std::cos(rx), -std::sin(rx), 0, std::sin(rx), std::cos(rx);
  rot_y << std::cos(ry), 0, std::sin(ry), 0, 1, 0, -std::sin(ry), 0, std::cos(ry);
  rot_z << std::cos(rz), -std::sin(rz), 0, std::sin(rz), std::cos(rz), 0, 0, 0, 1;
  const Pose p = Pose::fromXYZRPY(1.0, 2.0, 3.0, rx, ry, rz);
  EXPECT_LT((p.rotation.toRotationMatrix() - rot_z * rot_y * rot_x).norm(), kTol);
  EXPECT_EQ(p.translation, Eigen::Vector3d(1.0, 2.0, 3.0));
  EXPECT_NEAR(p.yaw(), rz, kTol);  // Z-Y-X yaw
}

TEST(Pose, FromSE2IsRotationAboutZ) {
  const Pose p = Pose::fromSE2(1.5, -2.5, 0.4);
  EXPECT_EQ(p.translation, Eigen::Vector3d(1.5, -2.5, 0.0));
  EXPECT_NEAR(p.rotation.w(), std::cos(0.2), kTol);
  EXPECT_NEAR(p.rotation.z(), std::sin(0.2), kTol);
  EXPECT_EQ(p.rotation.x(), 0.0);
  EXPECT_EQ(p.rotation.y(), 0.0);
  EXPECT_NEAR(p.yaw(), 0.4, kTol);
  // Headings outside (-pi, pi] are the same rotation and read back wrapped.
  EXPECT_NEAR(Pose::fromSE2(0, 0, 6.282233).yaw(), 6.282233 - 2 * M_PI, kTol);
  EXPECT_GE(Pose::fromSE2(0, 0, 6.282233).rotation.w(), 0.0);
  EXPECT_NEAR(Pose::fromSE2(0, 0, -3.5).yaw(), -3.5 + 2 * M_PI, kTol);
}

TEST(Pose, WrapAngleRange) {
  EXPECT_EQ(wrapAngle(0.5), 0.5);
  EXPECT_EQ(wrapAngle(-0.5), -0.5);
  EXPECT_EQ(wrapAngle(M_PI), M_PI);
  EXPECT_EQ(wrapAngle(-M_PI), M_PI);  // (-pi, pi]: the lower end maps up
  EXPECT_NEAR(wrapAngle(3 * M_PI), M_PI, 1e-12);
  EXPECT_NEAR(wrapAngle(-7.0), -7.0 + 2 * M_PI, kTol);
  EXPECT_NEAR(wrapAngle(7.0), 7.0 - 2 * M_PI, kTol);
  EXPECT_NEAR(wrapAngle(100.0), 100.0 - 32 * M_PI, 1e-12);
}

// The shortcut for angles already in (-pi, pi] returns what std::remainder
// does there, to the bit (the engine's results must not move with it).
TEST(Pose, WrapAngleAgreesWithRemainderToTheBit) {
  std::mt19937 random(5);
  std::uniform_real_distribution<double> angle(-4.0, 4.0);
  std::vector<double> angles{std::nextafter(-M_PI, 0.0), std::nextafter(M_PI, 0.0), -0.0, 0.0, 1e-300, M_PI};
  for (int k = 0; k < 100000; ++k) angles.push_back(angle(random));
  for (double a : angles) {
    double expected = std::remainder(a, 2.0 * M_PI);
    if (expected <= -M_PI) expected += 2.0 * M_PI;
    EXPECT_EQ(std::signbit(wrapAngle(a)), std::signbit(expected)) << a;
    EXPECT_EQ(wrapAngle(a), expected) << a;
  }
}

TEST(Pose, RelativePoseErrorZeroForConsistentPoses) {
  const Pose a2 = Pose::fromSE2(1.0, 2.0, 3.0);
  const Pose z2 = Pose::fromSE2(0.5, -0.3, 0.9);  // b's heading crosses +-pi
  EXPECT_LT(relativePoseError(2, a2, a2 * z2, z2).norm(), kTol);

  const Pose a3 = Pose::fromXYZRPY(1.0, -2.0, 0.5, 0.3, -0.7, 2.1);
  const Pose z3 = Pose::fromXYZRPY(0.2, 0.1, -0.4, 1.0, 0.5, -2.9);
  const Eigen::VectorXd e3 = relativePoseError(3, a3, a3 * z3, z3);
  ASSERT_EQ(e3.size(), 6);
  EXPECT_LT(e3.norm(), kTol);
}

// Expected SE(2) residual, worked out here from the Pose2 Logmap formula
// rho = V(theta)^-1 t, V = [[A, -B], [B, A]], A = sin(theta) / theta,
// B = (1 - cos(theta)) / theta: V^-1 = [[A, B], [-B, A]] / (A^2 + B^2).
Eigen::Vector3d expectedLogmap2D(double tx, double ty, double theta) {
  const double a = std::sin(theta) / theta;
  const double b = (1.0 - std::cos(theta)) / theta;
  const double det = a * a + b * b;
  return Eigen::Vector3d((a * tx + b * ty) / det, (-b * tx + a * ty) / det, theta);
}

// V(theta) rho: the translation the tangent vector maps back to.
Eigen::Vector2d expmapTranslation2D(const Eigen::VectorXd& xi) {
  const double theta = xi(2);
  const double a = std::sin(theta) / theta;
  const double b = (1.0 - std::cos(theta)) / theta;
  return Eigen::Vector2d(a * xi(0) - b * xi(1), b * xi(0) + a * xi(1));
}

TEST(Pose, RelativePoseErrorKnownOffset2D) {
  // a = identity, z = 1 m ahead turned 90 deg, b is 0.1 m further left and
  // 0.05 rad more turned: in z's frame the offset is t = (0.1, 0), dtheta = 0.05.
  // Logmap: B / (A^2 + B^2) = theta / 2 and A / (A^2 + B^2) = (theta / 2) cot(theta / 2),
  // so rho = (0.1 * 0.025 * cot(0.025), -0.1 * 0.025) = (0.0999791657985594..., -0.0025).
  const Pose z = Pose::fromSE2(1.0, 0.0, M_PI / 2);
  const Pose b = Pose::fromSE2(1.0, 0.1, M_PI / 2 + 0.05);
  const Eigen::VectorXd e = relativePoseError(2, Pose::identity(), b, z);
  ASSERT_EQ(e.size(), 3);
  EXPECT_NEAR(e(0), 0.1 * 0.025 / std::tan(0.025), kTol);
  EXPECT_NEAR(e(0), 0.0999791657985594379, kTol);
  EXPECT_NEAR(e(1), -0.0025, kTol);
  EXPECT_NEAR(e(2), 0.05, kTol);
  EXPECT_LT((e - expectedLogmap2D(0.1, 0.0, 0.05)).norm(), kTol);
  // Not the old plain [t, dtheta]: the rotation couples into rho.
  EXPECT_GT(std::abs(e(1)), 1e-3);
  // V(theta) rho gives the relative translation back.
  EXPECT_LT((expmapTranslation2D(e) - Eigen::Vector2d(0.1, 0.0)).norm(), kTol);

  // A quarter turn with t = (1, 0): A = B = 2 / pi, so rho = (pi / 4, -pi / 4).
  const Eigen::VectorXd quarter =
      relativePoseError(2, Pose::identity(), Pose::fromSE2(1.0, 0.0, M_PI / 2), Pose::identity());
  EXPECT_NEAR(quarter(0), M_PI / 4, kTol);
  EXPECT_NEAR(quarter(1), -M_PI / 4, kTol);
  EXPECT_NEAR(quarter(2), M_PI / 2, kTol);

  // A half turn with t = (0, 2): A = 0, B = 2 / pi, so rho = (pi, 0).
  const Eigen::VectorXd half =
      relativePoseError(2, Pose::identity(), Pose::fromSE2(0.0, 2.0, M_PI), Pose::identity());
  EXPECT_NEAR(half(0), M_PI, 1e-12);
  EXPECT_NEAR(half(1), 0.0, 1e-12);
  EXPECT_NEAR(half(2), M_PI, 1e-12);

  // A perturbation applied in z's frame is recovered as its own Logmap:
  // delta = (0.01, -0.02, 0.03) -> rho = V(0.03)^-1 (0.01, -0.02).
  const Pose a = Pose::fromSE2(-3.0, 4.0, 2.8);
  const Pose z2 = Pose::fromSE2(0.7, 0.2, 0.6);
  const Eigen::VectorXd e2 = relativePoseError(2, a, a * z2 * Pose::fromSE2(0.01, -0.02, 0.03), z2);
  EXPECT_NEAR(e2(0), 0.00969924998874975892, kTol);
  EXPECT_NEAR(e2(1), -0.0201484999774995178, kTol);
  EXPECT_NEAR(e2(2), 0.03, kTol);
  EXPECT_LT((e2 - expectedLogmap2D(0.01, -0.02, 0.03)).norm(), kTol);
  EXPECT_LT((expmapTranslation2D(e2) - Eigen::Vector2d(0.01, -0.02)).norm(), kTol);

  // The angle is wrapped: headings 3.0 and -3.0 differ by 2*pi - 6; no translation, so rho = 0.
  const Eigen::VectorXd wrapped =
      relativePoseError(2, Pose::fromSE2(0, 0, 3.0), Pose::fromSE2(0, 0, -3.0), Pose::identity());
  EXPECT_NEAR(wrapped(0), 0.0, kTol);
  EXPECT_NEAR(wrapped(1), 0.0, kTol);
  EXPECT_NEAR(wrapped(2), 2 * M_PI - 6.0, kTol);
}

TEST(Pose, RelativePoseErrorPureTranslation2D) {
  // No rotation: V = I, so the residual is exactly [dx, dy, 0].
  const Eigen::VectorXd e =
      relativePoseError(2, Pose::fromSE2(2.0, -1.0, 0.0), Pose::fromSE2(2.5, -0.75, 0.0), Pose::identity());
  ASSERT_EQ(e.size(), 3);
  EXPECT_EQ(e(0), 0.5);
  EXPECT_EQ(e(1), 0.25);
  EXPECT_EQ(e(2), 0.0);

  const Eigen::VectorXd offset = relativePoseError(2, Pose::identity(), Pose::fromSE2(0.3, -0.2, 0.0),
                                                   Pose::fromSE2(0.25, -0.125, 0.0));
  EXPECT_EQ(offset(0), 0.3 - 0.25);
  EXPECT_EQ(offset(1), -0.2 + 0.125);
  EXPECT_EQ(offset(2), 0.0);

  // Same heading on both ends, offset given in a's frame.
  const Pose a = Pose::fromSE2(-3.0, 4.0, 0.8);
  const Eigen::VectorXd rotated = relativePoseError(2, a, a * Pose::fromSE2(0.4, -0.6, 0.0), Pose::identity());
  EXPECT_NEAR(rotated(0), 0.4, kTol);
  EXPECT_NEAR(rotated(1), -0.6, kTol);
  EXPECT_NEAR(rotated(2), 0.0, kTol);
}

TEST(Pose, RelativePoseErrorKnownOffset3D) {
  Pose b;
  b.translation = Eigen::Vector3d(1.0, 2.0, 3.0);
  b.rotation = Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX());
  Eigen::VectorXd e = relativePoseError(3, Pose::identity(), b, Pose::identity());
  ASSERT_EQ(e.size(), 6);
  Eigen::VectorXd expected(6);
  expected << 1.0, 2.0, 3.0, 2.0 * std::sin(0.1), 0.0, 0.0;
  EXPECT_LT((e - expected).norm(), kTol);

  // A rotation of 2*pi - 0.2 about x is -0.2 about x: w >= 0 picks the small
  // residual, not the one near 2.
  b.rotation = Eigen::AngleAxisd(2 * M_PI - 0.2, Eigen::Vector3d::UnitX());
  ASSERT_LT(b.rotation.w(), 0.0);
  e = relativePoseError(3, Pose::identity(), b, Pose::identity());
  expected << 1.0, 2.0, 3.0, -2.0 * std::sin(0.1), 0.0, 0.0;
  EXPECT_LT((e - expected).norm(), kTol);

  // A perturbation applied in z's frame comes back as [t, 2 vec(q)].
  const Pose a = Pose::fromXYZRPY(1.0, -2.0, 0.5, 0.3, -0.7, 2.1);
  const Pose z = Pose::fromXYZRPY(0.2, 0.1, -0.4, 1.0, 0.5, -2.9);
  const Pose delta = Pose::fromXYZRPY(0.01, -0.02, 0.03, 0.004, -0.005, 0.006);
  e = relativePoseError(3, a, a * z * delta, z);
  expected << 0.01, -0.02, 0.03, 2.0 * delta.rotation.x(), 2.0 * delta.rotation.y(),
      2.0 * delta.rotation.z();
  EXPECT_LT((e - expected).norm(), kTol);
}

}  // namespace
}  // namespace core
}  // namespace agnc_pgo
