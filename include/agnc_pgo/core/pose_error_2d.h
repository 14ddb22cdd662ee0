// Relative-pose error term for SE(2), in the style of Ceres'
// examples/slam/pose_graph_2d.
//
// Parameter blocks: pose a = [x_a, y_a, yaw_a], pose b = [x_b, y_b, yaw_b].
// Measurement z = (t_z, yaw_z): the pose of b in a's frame. The error is
// the SE(2) logarithm of z^-1 * (a^-1 * b) (GTSAM's Pose2 Local()):
//
//   d_t   = R(yaw_z)^T (R(yaw_a)^T (t_b - t_a) - t_z)
//   theta = wrap(yaw_b - yaw_a - yaw_z)
//   e     = [V(theta)^-1 d_t, theta]          (see se2_logmap.h)
//
// and the residual is the whitened error S e with S^T S = information, so the
// robust kernel sees r = |S e|, the Mahalanobis distance.
#pragma once

#include <ceres/autodiff_cost_function.h>
#include <Eigen/Core>

#include "agnc_pgo/core/se2_logmap.h"

namespace agnc_pgo {
namespace core {

template <typename T>
T wrapAngleT(const T& angle) {
  const T two_pi(2.0 * M_PI);
  using std::floor;
  return angle - two_pi * floor((angle + T(M_PI)) / two_pi);
}

class PoseError2d {
 public:
  PoseError2d(const Eigen::Vector3d& measurement, const Eigen::Matrix3d& sqrt_information)
      : z_(measurement), sqrt_information_(sqrt_information) {}

  template <typename T>
  bool operator()(const T* const a, const T* const b, T* residual) const {
    using std::cos;
    using std::sin;
    const T dx = b[0] - a[0];
    const T dy = b[1] - a[1];
    const T ca = cos(a[2]), sa = sin(a[2]);
    // t_ab = R(yaw_a)^T (t_b - t_a)
    const T tx = ca * dx + sa * dy;
    const T ty = -sa * dx + ca * dy;
    const T cz(cos(z_(2))), sz(sin(z_(2)));
    const T d_x = cz * (tx - T(z_(0))) + sz * (ty - T(z_(1)));
    const T d_y = -sz * (tx - T(z_(0))) + cz * (ty - T(z_(1)));
    Eigen::Matrix<T, 3, 1> e;
    se2Logmap(d_x, d_y, wrapAngleT(b[2] - a[2] - T(z_(2))), e.data());
    Eigen::Map<Eigen::Matrix<T, 3, 1>> r(residual);
    r = sqrt_information_.template cast<T>() * e;
    return true;
  }

  static ceres::CostFunction* create(const Eigen::Vector3d& measurement,
                                     const Eigen::Matrix3d& sqrt_information) {
    return new ceres::AutoDiffCostFunction<PoseError2d, 3, 3, 3>(
        new PoseError2d(measurement, sqrt_information));
  }

  EIGEN_MAKE_ALIGNED_OPERATOR_NEW

 private:
  Eigen::Vector3d z_;
  Eigen::Matrix3d sqrt_information_;
};

}  // namespace core
}  // namespace agnc_pgo
