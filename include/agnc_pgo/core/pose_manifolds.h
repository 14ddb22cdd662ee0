// Manifolds of the pose parameter blocks and conversions between the plain
// Pose type and those blocks.
//
// SE(2): [x, y, yaw], tangent [dx, dy, dyaw], yaw kept in (-pi, pi].
// SE(3): [x, y, z, qx, qy, qz, qw] = R^3 x unit quaternions, Ceres'
//        ProductManifold<EuclideanManifold<3>, EigenQuaternionManifold>
//        (tangent [dp, dtheta]; q+ = exp(dtheta) * q).
#pragma once

#include <array>
#include <memory>

#include <ceres/cost_function.h>
#include <ceres/manifold.h>

#include "agnc_pgo/core/pose.h"

namespace agnc_pgo {
namespace core {

using PoseBlock = std::array<double, 7>;  // SE(2) uses the first 3 entries

class Pose2Manifold : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 3; }
  int TangentSize() const override { return 3; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

// A new manifold for a pose block of the given dimension (2 or 3).
std::unique_ptr<ceres::Manifold> makePoseManifold(int dimension);

PoseBlock toBlock(int dimension, const Pose& pose);
Pose fromBlock(int dimension, const PoseBlock& block);

// Upper-triangular S with S^T S = information (Cholesky); throws
// std::invalid_argument if the information is not positive definite.
Eigen::MatrixXd sqrtInformation(const Eigen::MatrixXd& information);

// The error-term cost function for an edge of the given dimension.
ceres::CostFunction* makePoseErrorCost(int dimension, const Pose& measurement,
                                       const Eigen::MatrixXd& information);

}  // namespace core
}  // namespace agnc_pgo
