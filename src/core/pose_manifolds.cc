#include "agnc_pgo/core/pose_manifolds.h"

#include <stdexcept>

#include <ceres/product_manifold.h>
#include <Eigen/Cholesky>

#include "agnc_pgo/core/pose_error_2d.h"
#include "agnc_pgo/core/pose_error_3d.h"

namespace agnc_pgo {
namespace core {

bool Pose2Manifold::Plus(const double* x, const double* delta, double* out) const {
  out[0] = x[0] + delta[0];
  out[1] = x[1] + delta[1];
  out[2] = wrapAngle(x[2] + delta[2]);
  return true;
}

bool Pose2Manifold::PlusJacobian(const double*, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(jacobian).setIdentity();
  return true;
}

bool Pose2Manifold::Minus(const double* y, const double* x, double* out) const {
  out[0] = y[0] - x[0];
  out[1] = y[1] - x[1];
  out[2] = wrapAngle(y[2] - x[2]);
  return true;
}

bool Pose2Manifold::MinusJacobian(const double*, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(jacobian).setIdentity();
  return true;
}

std::unique_ptr<ceres::Manifold> makePoseManifold(int dimension) {
  if (dimension == 2) return std::make_unique<Pose2Manifold>();
  using Pose3Manifold =
      ceres::ProductManifold<ceres::EuclideanManifold<3>, ceres::EigenQuaternionManifold>;
  return std::make_unique<Pose3Manifold>();
}

PoseBlock toBlock(int dimension, const Pose& pose) {
  PoseBlock b{};
  if (dimension == 2) {
    b[0] = pose.translation.x();
    b[1] = pose.translation.y();
    b[2] = pose.yaw();
  } else {
    const Eigen::Quaterniond q = pose.rotation.normalized();
    b = {pose.translation.x(), pose.translation.y(), pose.translation.z(),
         q.x(), q.y(), q.z(), q.w()};
  }
  return b;
}

Pose fromBlock(int dimension, const PoseBlock& b) {
  if (dimension == 2) return Pose::fromSE2(b[0], b[1], b[2]);
  Pose pose;
  pose.translation = Eigen::Vector3d(b[0], b[1], b[2]);
  pose.rotation = Eigen::Quaterniond(b[6], b[3], b[4], b[5]).normalized();
  return pose;
}

Eigen::MatrixXd sqrtInformation(const Eigen::MatrixXd& information) {
  Eigen::LLT<Eigen::MatrixXd> llt(0.5 * (information + information.transpose()));
  if (llt.info() != Eigen::Success)
    throw std::invalid_argument("information matrix is not positive definite");
  return llt.matrixU();
}

ceres::CostFunction* makePoseErrorCost(int dimension, const Pose& z,
                                       const Eigen::MatrixXd& information) {
  const Eigen::MatrixXd s = sqrtInformation(information);
  if (dimension == 2) {
    if (s.rows() != 3) throw std::invalid_argument("SE(2) edges need a 3x3 information matrix");
    return PoseError2d::create(Eigen::Vector3d(z.translation.x(), z.translation.y(), z.yaw()),
                               s);
  }
  if (s.rows() != 6) throw std::invalid_argument("SE(3) edges need a 6x6 information matrix");
  return PoseError3d::create(z.translation, z.rotation.normalized(), s);
}

}  // namespace core
}  // namespace agnc_pgo
