// The SE(2) and SE(3) error terms: analytic Jacobians against automatic and
// numeric differentiation, and zero error for consistent poses.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>

#include <ceres/numeric_diff_cost_function.h>

#include "agnc_pgo/core/pose_error_2d.h"
#include "agnc_pgo/core/pose_error_3d.h"
#include "agnc_pgo/core/pose_manifolds.h"

using namespace agnc_pgo::core;

namespace {

// Compares the Jacobians of two cost functions at the given blocks.
void expectSameJacobians(const ceres::CostFunction& analytic, const ceres::CostFunction& numeric,
                         const double* a, const double* b, int residuals, int ambient, double tol) {
  const double* parameters[2] = {a, b};
  std::vector<double> r1(residuals), r2(residuals);
  std::vector<double> ja1(residuals * ambient), jb1(residuals * ambient);
  std::vector<double> ja2(residuals * ambient), jb2(residuals * ambient);
  double* j1[2] = {ja1.data(), jb1.data()};
  double* j2[2] = {ja2.data(), jb2.data()};
  ASSERT_TRUE(analytic.Evaluate(parameters, r1.data(), j1));
  ASSERT_TRUE(numeric.Evaluate(parameters, r2.data(), j2));
  for (int i = 0; i < residuals; ++i) EXPECT_NEAR(r1[i], r2[i], 1e-12);
  for (size_t i = 0; i < ja1.size(); ++i) {
    EXPECT_NEAR(ja1[i], ja2[i], tol) << "d r / d a, entry " << i;
    EXPECT_NEAR(jb1[i], jb2[i], tol) << "d r / d b, entry " << i;
  }
}

Eigen::MatrixXd randomInformation(int n, std::mt19937* rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::MatrixXd a(n, n);
  for (int i = 0; i < n * n; ++i) a(i) = u(*rng);
  return a * a.transpose() + n * Eigen::MatrixXd::Identity(n, n);
}

}  // namespace

TEST(PoseError2d, JacobiansMatchNumericDifferentiation) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Vector3d z(u(rng), u(rng), u(rng));
    const Eigen::Matrix3d s = sqrtInformation(randomInformation(3, &rng));
    const double a[3] = {u(rng), u(rng), u(rng)};
    const double b[3] = {u(rng), u(rng), u(rng)};
    std::unique_ptr<ceres::CostFunction> analytic(PoseError2d::create(z, s));
    ceres::NumericDiffCostFunction<PoseError2d, ceres::CENTRAL, 3, 3, 3> numeric(new PoseError2d(z, s));
    expectSameJacobians(*analytic, numeric, a, b, 3, 3, 1e-6);
  }
}

TEST(PoseError2d, AnalyticJacobiansMatchAutomaticDifferentiation) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Vector3d z(u(rng), u(rng), u(rng));
    const Eigen::Matrix3d s = sqrtInformation(randomInformation(3, &rng));
    const double a[3] = {u(rng), u(rng), u(rng)};
    double b[3] = {u(rng), u(rng), u(rng)};
    // Every fourth trial lands near theta = 0 (and one exactly on it), where
    // the Taylor branch takes over.
    if (trial % 4 == 0) b[2] = a[2] + z(2) + (trial == 0 ? 0.0 : 1e-6 * u(rng));
    std::unique_ptr<ceres::CostFunction> analytic(PoseError2d::create(z, s));
    std::unique_ptr<ceres::CostFunction> automatic(PoseError2d::createAutoDiff(z, s));
    expectSameJacobians(*analytic, *automatic, a, b, 3, 3, 1e-9);
  }
}

namespace {

// A random SE(3) case for the error term: poses a and b, measurement z and a
// non-diagonal square-root information. Every third case puts the rotation
// error near pi (dq's w near zero, on either side), and the quaternions of a
// and b get a random sign, so both branches of the sign flip are taken.
struct Case3d {
  std::array<double, 7> a, b;
  Eigen::Vector3d p_z;
  Eigen::Quaterniond q_z;
  Eigen::Matrix<double, 6, 6> s;
};

Eigen::Quaterniond randomRotation(std::mt19937* rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return Eigen::Quaterniond(n(*rng), n(*rng), n(*rng), n(*rng)).normalized();
}

std::array<double, 7> toArray(const Eigen::Vector3d& p, const Eigen::Quaterniond& q) {
  return {p.x(), p.y(), p.z(), q.x(), q.y(), q.z(), q.w()};
}

Case3d randomCase3d(int trial, std::mt19937* rng) {
  std::uniform_real_distribution<double> u(-5.0, 5.0);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  Case3d c;
  const Eigen::Vector3d p_a(u(*rng), u(*rng), u(*rng));
  const Eigen::Quaterniond q_a = randomRotation(rng);
  c.p_z = Eigen::Vector3d(u(*rng), u(*rng), u(*rng));
  c.q_z = randomRotation(rng);
  Eigen::Quaterniond q_b;
  Eigen::Vector3d p_b;
  if (trial % 3 == 0) {
    // b = a z delta with delta a rotation by pi +- 1e-3 (or a small angle).
    const Eigen::Vector3d axis = Eigen::Vector3d(unit(*rng), unit(*rng), unit(*rng)).normalized();
    const double angle = trial % 2 == 0 ? M_PI + 1e-3 * unit(*rng) : 1e-3 * unit(*rng);
    const Eigen::Quaterniond delta(Eigen::AngleAxisd(angle, axis));
    q_b = q_a * c.q_z * delta;
    p_b = p_a + q_a * c.p_z + Eigen::Vector3d(unit(*rng), unit(*rng), unit(*rng));
  } else {
    q_b = randomRotation(rng);
    p_b = Eigen::Vector3d(u(*rng), u(*rng), u(*rng));
  }
  const double sign_a = unit(*rng) < 0.0 ? -1.0 : 1.0;
  const double sign_b = unit(*rng) < 0.0 ? -1.0 : 1.0;
  c.a = toArray(p_a, Eigen::Quaterniond(sign_a * q_a.coeffs()));
  c.b = toArray(p_b, Eigen::Quaterniond(sign_b * q_b.coeffs()));
  c.s = sqrtInformation(randomInformation(6, rng) * (trial % 5 == 0 ? 100.0 : 1.0));
  return c;
}

// The w of the case's rotation error before the sign flip.
double errorW(const Case3d& c) {
  const Eigen::Quaterniond q_a(c.a[6], c.a[3], c.a[4], c.a[5]);
  const Eigen::Quaterniond q_b(c.b[6], c.b[3], c.b[4], c.b[5]);
  return (c.q_z.conjugate() * (q_a.conjugate() * q_b)).w();
}

}  // namespace

TEST(PoseError3d, JacobiansMatchNumericDifferentiation) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 60; ++trial) {
    const Case3d c = randomCase3d(trial, &rng);
    std::unique_ptr<ceres::CostFunction> analytic(PoseError3d::create(c.p_z, c.q_z, c.s));
    ceres::NumericDiffCostFunction<PoseError3d, ceres::CENTRAL, 6, 7, 7> numeric(
        new PoseError3d(c.p_z, c.q_z, c.s));
    SCOPED_TRACE(trial);
    expectSameJacobians(*analytic, numeric, c.a.data(), c.b.data(), 6, 7, 1e-5);
  }
}

TEST(PoseError3d, AnalyticJacobiansMatchAutomaticDifferentiation) {
  std::mt19937 rng(13);
  int flipped = 0, near_pi = 0;
  for (int trial = 0; trial < 300; ++trial) {
    Case3d c = randomCase3d(trial, &rng);
    // The ambient Jacobians are those of the expression, off the unit sphere
    // too: every seventh case scales a's and b's quaternions.
    if (trial % 7 == 0)
      for (int i = 3; i < 7; ++i) c.a[i] *= 1.1, c.b[i] *= 0.9;
    flipped += errorW(c) < 0.0;
    near_pi += std::abs(errorW(c)) < 1e-2;
    std::unique_ptr<ceres::CostFunction> analytic(PoseError3d::create(c.p_z, c.q_z, c.s));
    std::unique_ptr<ceres::CostFunction> automatic(PoseError3d::createAutoDiff(c.p_z, c.q_z, c.s));
    SCOPED_TRACE(trial);
    expectSameJacobians(*analytic, *automatic, c.a.data(), c.b.data(), 6, 7, 1e-9);
    // Residual alone (no Jacobians requested) is the same too.
    const double* parameters[2] = {c.a.data(), c.b.data()};
    double r1[6], r2[6];
    ASSERT_TRUE(analytic->Evaluate(parameters, r1, nullptr));
    ASSERT_TRUE(automatic->Evaluate(parameters, r2, nullptr));
    for (int i = 0; i < 6; ++i) EXPECT_NEAR(r1[i], r2[i], 1e-12 * (1.0 + std::abs(r2[i])));
  }
  EXPECT_GT(flipped, 50);
  EXPECT_GT(near_pi, 40);
}

// Only one Jacobian requested (the solver's anchored factors): the same
// values as when both are.
TEST(PoseError3d, SingleJacobianMatchesBoth) {
  std::mt19937 rng(17);
  const Case3d c = randomCase3d(1, &rng);
  std::unique_ptr<ceres::CostFunction> cost(PoseError3d::create(c.p_z, c.q_z, c.s));
  const double* parameters[2] = {c.a.data(), c.b.data()};
  double r[6], ja[42], jb[42], ja1[42], jb1[42];
  double* both[2] = {ja, jb};
  double* only_a[2] = {ja1, nullptr};
  double* only_b[2] = {nullptr, jb1};
  ASSERT_TRUE(cost->Evaluate(parameters, r, both));
  ASSERT_TRUE(cost->Evaluate(parameters, r, only_a));
  ASSERT_TRUE(cost->Evaluate(parameters, r, only_b));
  for (int i = 0; i < 42; ++i) {
    EXPECT_EQ(ja[i], ja1[i]);
    EXPECT_EQ(jb[i], jb1[i]);
  }
}

TEST(PoseError, ZeroForConsistentPosesAndMatchesRelativePoseError) {
  for (int dim : {2, 3}) {
    const Pose a = dim == 2 ? Pose::fromSE2(1.0, -2.0, 0.7) : Pose::fromXYZRPY(1, -2, 0.5, 0.1, -0.2, 0.7);
    const Pose z = dim == 2 ? Pose::fromSE2(0.3, 0.4, -0.2) : Pose::fromXYZRPY(0.3, 0.4, -0.1, 0.05, 0.2, -0.2);
    const Pose b = a * z;
    const int n = dim == 2 ? 3 : 6;
    std::unique_ptr<ceres::CostFunction> cost(makePoseErrorCost(dim, z, Eigen::MatrixXd::Identity(n, n)));
    const PoseBlock ba = toBlock(dim, a), bb = toBlock(dim, b);
    const double* parameters[2] = {ba.data(), bb.data()};
    double r[6];
    ASSERT_TRUE(cost->Evaluate(parameters, r, nullptr));
    for (int i = 0; i < n; ++i) EXPECT_NEAR(r[i], 0.0, 1e-12);

    // A perturbed b: the residual equals the library's relativePoseError.
    const Pose b2 = dim == 2 ? b * Pose::fromSE2(0.1, -0.05, 0.03) : b * Pose::fromXYZRPY(0.1, -0.05, 0.02, 0.01, 0.02, 0.03);
    const PoseBlock bb2 = toBlock(dim, b2);
    const double* parameters2[2] = {ba.data(), bb2.data()};
    ASSERT_TRUE(cost->Evaluate(parameters2, r, nullptr));
    const Eigen::VectorXd e = relativePoseError(dim, a, b2, z);
    for (int i = 0; i < n; ++i) EXPECT_NEAR(r[i], e(i), 1e-9);
  }
}

TEST(Pose2Manifold, PlusWrapsYaw) {
  Pose2Manifold m;
  const double x[3] = {1, 2, 3.0};
  const double d[3] = {0.5, -1, 0.5};
  double out[3];
  m.Plus(x, d, out);
  EXPECT_NEAR(out[0], 1.5, 1e-15);
  EXPECT_NEAR(out[1], 1.0, 1e-15);
  EXPECT_NEAR(out[2], 3.5 - 2 * M_PI, 1e-12);
  double back[3];
  m.Minus(out, x, back);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(back[i], d[i], 1e-12);
}
