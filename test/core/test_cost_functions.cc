// The SE(2) and SE(3) error terms: automatic Jacobians against numeric
// differentiation, and zero error for consistent poses.
#include <gtest/gtest.h>

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

TEST(PoseError3d, JacobiansMatchNumericDifferentiation) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto random_block = [&]() {
    const Eigen::Quaterniond q = Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized();
    return std::array<double, 7>{u(rng), u(rng), u(rng), q.x(), q.y(), q.z(), q.w()};
  };
  for (int trial = 0; trial < 20; ++trial) {
    const std::array<double, 7> a = random_block(), b = random_block(), zb = random_block();
    const Eigen::Vector3d p_z(zb[0], zb[1], zb[2]);
    const Eigen::Quaterniond q_z(zb[6], zb[3], zb[4], zb[5]);
    const Eigen::Matrix<double, 6, 6> s = sqrtInformation(randomInformation(6, &rng));
    std::unique_ptr<ceres::CostFunction> analytic(PoseError3d::create(p_z, q_z, s));
    ceres::NumericDiffCostFunction<PoseError3d, ceres::CENTRAL, 6, 7, 7> numeric(new PoseError3d(p_z, q_z, s));
    expectSameJacobians(*analytic, numeric, a.data(), b.data(), 6, 7, 1e-6);
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
