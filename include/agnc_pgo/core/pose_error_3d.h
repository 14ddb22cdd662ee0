// Relative-pose error term for SE(3), in the style of Ceres'
// examples/slam/pose_graph_3d, with one 7-double parameter block per pose
// [p_x, p_y, p_z, q_x, q_y, q_z, q_w] (Eigen's quaternion memory order).
//
// Measurement z = (p_z, q_z): the pose of b in a's frame. The error is
// z^-1 * (a^-1 * b) as a vector:
//
//   p_ab = R(q_a)^T (p_b - p_a),  q_ab = q_a^-1 q_b
//   e_p  = R(q_z)^T (p_ab - p_z)
//   e_q  = 2 vec(q_z^-1 q_ab)      (sign chosen so that w >= 0)
//
// 2 vec(q) equals the rotation vector to first order, the same scale as the
// information's rotation block. The residual is S e with S^T S = information.
#pragma once

#include <ceres/autodiff_cost_function.h>
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace agnc_pgo {
namespace core {

class PoseError3d {
 public:
  PoseError3d(const Eigen::Vector3d& p_z, const Eigen::Quaterniond& q_z,
              const Eigen::Matrix<double, 6, 6>& sqrt_information)
      : p_z_(p_z), q_z_(q_z), sqrt_information_(sqrt_information) {}

  template <typename T>
  bool operator()(const T* const a, const T* const b, T* residual) const {
    Eigen::Map<const Eigen::Matrix<T, 3, 1>> p_a(a);
    Eigen::Map<const Eigen::Quaternion<T>> q_a(a + 3);
    Eigen::Map<const Eigen::Matrix<T, 3, 1>> p_b(b);
    Eigen::Map<const Eigen::Quaternion<T>> q_b(b + 3);

    const Eigen::Quaternion<T> q_a_inverse = q_a.conjugate();
    const Eigen::Matrix<T, 3, 1> p_ab = q_a_inverse * (p_b - p_a);
    const Eigen::Quaternion<T> q_ab = q_a_inverse * q_b;

    const Eigen::Quaternion<T> q_z_inverse = q_z_.conjugate().template cast<T>();
    Eigen::Quaternion<T> dq = q_z_inverse * q_ab;
    if (dq.w() < T(0)) dq.coeffs() = -dq.coeffs();

    Eigen::Matrix<T, 6, 1> e;
    e.template head<3>() = q_z_inverse * (p_ab - p_z_.template cast<T>());
    e.template tail<3>() = T(2.0) * dq.vec();
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residual);
    r = sqrt_information_.template cast<T>() * e;
    return true;
  }

  static ceres::CostFunction* create(const Eigen::Vector3d& p_z, const Eigen::Quaterniond& q_z,
                                     const Eigen::Matrix<double, 6, 6>& sqrt_information) {
    return new ceres::AutoDiffCostFunction<PoseError3d, 6, 7, 7>(
        new PoseError3d(p_z, q_z, sqrt_information));
  }

  EIGEN_MAKE_ALIGNED_OPERATOR_NEW

 private:
  Eigen::Vector3d p_z_;
  Eigen::Quaterniond q_z_;
  Eigen::Matrix<double, 6, 6> sqrt_information_;
};

}  // namespace core
}  // namespace agnc_pgo
