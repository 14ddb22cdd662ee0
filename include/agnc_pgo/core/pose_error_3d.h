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
#include <ceres/sized_cost_function.h>
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

  // The automatically differentiated cost (the reference for the analytic one).
  static ceres::CostFunction* createAutoDiff(const Eigen::Vector3d& p_z,
                                             const Eigen::Quaterniond& q_z,
                                             const Eigen::Matrix<double, 6, 6>& sqrt_information) {
    return new ceres::AutoDiffCostFunction<PoseError3d, 6, 7, 7>(
        new PoseError3d(p_z, q_z, sqrt_information));
  }
  // The cost the solver uses: the same error with analytic Jacobians
  // (PoseError3dAnalytic below).
  static ceres::CostFunction* create(const Eigen::Vector3d& p_z, const Eigen::Quaterniond& q_z,
                                     const Eigen::Matrix<double, 6, 6>& sqrt_information);

  EIGEN_MAKE_ALIGNED_OPERATOR_NEW

 private:
  Eigen::Vector3d p_z_;
  Eigen::Quaterniond q_z_;
  Eigen::Matrix<double, 6, 6> sqrt_information_;
};

// The SE(3) error above with hand-derived Jacobians in the 7-D ambient
// parameters, exactly those automatic differentiation finds (the solver
// projects them onto the tangent space with the manifold's PlusJacobian).
//
// A quaternion q = (v, w) rotates x as Eigen does, by the polynomial
//   rot(q, x) = x + 2 w (v x x) + 2 v x (v x x),
// which is R(q) x for a unit q. Its derivatives, off the unit sphere too:
//   d rot / dx = I + 2 w [v]x + 2 [v]x^2                          =: M(q)
//   d rot / dw = 2 v x x
//   d rot / dv = -2 w [x]x + 2 (v x^T + (v . x) I - 2 x v^T)
// With d = p_b - p_a, conj(q_a) = (-v_a, w_a) and q_z a unit quaternion:
//   e_p = R_z^T (rot(conj(q_a), d) - p_z)
//   de_p/dp_b = R_z^T M(conj(q_a)) = -de_p/dp_a,   M(conj(q_a)) = I - 2 w_a [v_a]x + 2 [v_a]x^2
//   de_p/dw_a = -2 R_z^T (v_a x d)
//   de_p/dv_a = R_z^T (2 w_a [d]x + 2 (v_a d^T + (v_a . d) I - 2 d v_a^T))
// The rotation error is bilinear in the quaternions. In [x y z w] order,
// p q = L(p) q = R(q) p with
//   L(p) = [w_p I + [v_p]x, v_p; -v_p^T, w_p],  R(q) = [w_q I - [v_q]x, v_q; -v_q^T, w_q],
// dq = conj(q_z) conj(q_a) q_b, s = -1 if dq_w < 0 else 1, e_q = 2 s vec(dq):
//   de_q/dq_b = 2 s P L(conj(q_z) conj(q_a))
//   de_q/dq_a = 2 s P L(conj(q_z)) R(q_b) C,   P = [I 0] (3x4), C = diag(-1, -1, -1, 1)
// e_p does not depend on q_b, e_q not on the positions. The residual and the
// Jacobians are then multiplied by S.
class PoseError3dAnalytic : public ceres::SizedCostFunction<6, 7, 7> {
 public:
  PoseError3dAnalytic(const Eigen::Vector3d& p_z, const Eigen::Quaterniond& q_z,
                      const Eigen::Matrix<double, 6, 6>& sqrt_information)
      : p_z_(p_z),
        q_z_inverse_(q_z.conjugate()),
        sqrt_information_(sqrt_information),
        s_rz_t_(sqrt_information.leftCols<3>() * rotationJacobian(-q_z.vec(), q_z.w())) {
    // L(conj(q_z)), its top three rows.
    const Eigen::Vector3d v = q_z_inverse_.vec();
    const double w = q_z_inverse_.w();
    l_z_.leftCols<3>() = w * Eigen::Matrix3d::Identity() + skew(v);
    l_z_.col(3) = v;
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    Eigen::Map<const Eigen::Vector3d> p_a(parameters[0]);
    const Eigen::Map<const Eigen::Quaterniond> q_a(parameters[0] + 3);
    Eigen::Map<const Eigen::Vector3d> p_b(parameters[1]);
    const Eigen::Map<const Eigen::Quaterniond> q_b(parameters[1] + 3);

    // The residual, as the functor computes it.
    const Eigen::Quaterniond q_a_inverse = q_a.conjugate();
    const Eigen::Vector3d d = p_b - p_a;
    const Eigen::Vector3d p_ab = q_a_inverse * d;
    const Eigen::Quaterniond q_ab = q_a_inverse * q_b;
    Eigen::Quaterniond dq = q_z_inverse_ * q_ab;
    const double sign = dq.w() < 0.0 ? -1.0 : 1.0;
    if (sign < 0.0) dq.coeffs() = -dq.coeffs();
    Eigen::Matrix<double, 6, 1> e;
    e.head<3>() = q_z_inverse_ * (p_ab - p_z_);
    e.tail<3>() = 2.0 * dq.vec();
    Eigen::Map<Eigen::Matrix<double, 6, 1>> r(residuals);
    r.noalias() = sqrt_information_ * e;
    if (jacobians == nullptr) return true;

    using Jacobian = Eigen::Matrix<double, 6, 7, Eigen::RowMajor>;
    using Matrix34 = Eigen::Matrix<double, 3, 4>;
    const Eigen::Vector3d v_a = q_a.vec();
    const double w_a = q_a.w();
    const Eigen::Matrix3d v_a_skew = skew(v_a);
    // S [R_z^T M(conj(q_a)); 0]: the whitened d/dp_b, and -d/dp_a.
    const Eigen::Matrix3d m_a = rotationJacobian(-v_a, w_a);
    const Eigen::Matrix<double, 6, 3> j_p = s_rz_t_ * m_a;

    if (jacobians[0] != nullptr) {
      // [R_z^T d/dv_a, R_z^T d/dw_a] before R_z^T.
      Matrix34 t;
      t.leftCols<3>() = 2.0 * w_a * skew(d) +
                        2.0 * (v_a * d.transpose() + v_a.dot(d) * Eigen::Matrix3d::Identity() -
                               2.0 * d * v_a.transpose());
      t.col(3) = -2.0 * v_a.cross(d);
      // 2 s P L(conj(q_z)) R(q_b) C.
      Eigen::Matrix4d rc;
      const Eigen::Vector3d v_b = q_b.vec();
      const double w_b = q_b.w();
      rc.topLeftCorner<3, 3>() = -(w_b * Eigen::Matrix3d::Identity() - skew(v_b));
      rc.topRightCorner<3, 1>() = v_b;
      rc.bottomLeftCorner<1, 3>() = v_b.transpose();
      rc(3, 3) = w_b;
      const Matrix34 rot = (2.0 * sign) * (l_z_ * rc);
      Eigen::Map<Jacobian> j(jacobians[0]);
      j.leftCols<3>() = -j_p;
      j.rightCols<4>().noalias() = s_rz_t_ * t;
      j.rightCols<4>().noalias() += sqrt_information_.rightCols<3>() * rot;
    }
    if (jacobians[1] != nullptr) {
      // 2 s P L(conj(q_z) conj(q_a)) = 2 s P L(conj(q_z)) L(conj(q_a)).
      Eigen::Matrix4d l_a;
      l_a.topLeftCorner<3, 3>() = w_a * Eigen::Matrix3d::Identity() - v_a_skew;
      l_a.topRightCorner<3, 1>() = -v_a;
      l_a.bottomLeftCorner<1, 3>() = v_a.transpose();
      l_a(3, 3) = w_a;
      const Matrix34 rot = (2.0 * sign) * (l_z_ * l_a);
      Eigen::Map<Jacobian> j(jacobians[1]);
      j.leftCols<3>() = j_p;
      j.rightCols<4>().noalias() = sqrt_information_.rightCols<3>() * rot;
    }
    return true;
  }

  EIGEN_MAKE_ALIGNED_OPERATOR_NEW

 private:
  static Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
    Eigen::Matrix3d m;
    m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
    return m;
  }
  // M(q) = d rot(q, x) / dx = I + 2 w [v]x + 2 [v]x^2 (R(q) for a unit q).
  static Eigen::Matrix3d rotationJacobian(const Eigen::Vector3d& v, double w) {
    const Eigen::Matrix3d k = skew(v);
    return Eigen::Matrix3d::Identity() + 2.0 * w * k + 2.0 * k * k;
  }

  Eigen::Vector3d p_z_;
  Eigen::Quaterniond q_z_inverse_;
  Eigen::Matrix<double, 6, 6> sqrt_information_;
  Eigen::Matrix<double, 6, 3> s_rz_t_;  // S's first three columns times R_z^T
  Eigen::Matrix<double, 3, 4> l_z_;     // the top rows of L(conj(q_z))
};

inline ceres::CostFunction* PoseError3d::create(
    const Eigen::Vector3d& p_z, const Eigen::Quaterniond& q_z,
    const Eigen::Matrix<double, 6, 6>& sqrt_information) {
  return new PoseError3dAnalytic(p_z, q_z, sqrt_information);
}

}  // namespace core
}  // namespace agnc_pgo
