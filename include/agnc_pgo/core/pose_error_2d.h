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
#include <ceres/sized_cost_function.h>
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

  // The automatically differentiated cost (the reference for the analytic one).
  static ceres::CostFunction* createAutoDiff(const Eigen::Vector3d& measurement,
                                             const Eigen::Matrix3d& sqrt_information) {
    return new ceres::AutoDiffCostFunction<PoseError2d, 3, 3, 3>(
        new PoseError2d(measurement, sqrt_information));
  }
  // The cost the solver uses: the same error with analytic Jacobians
  // (PoseError2dAnalytic below), about four times cheaper to linearise.
  static ceres::CostFunction* create(const Eigen::Vector3d& measurement,
                                     const Eigen::Matrix3d& sqrt_information);

  EIGEN_MAKE_ALIGNED_OPERATOR_NEW

 private:
  Eigen::Vector3d z_;
  Eigen::Matrix3d sqrt_information_;
};

// The SE(2) error above with hand-derived Jacobians. With
//   D = R(yaw_z)^T R(yaw_a)^T,  d = D (t_b - t_a) - R(yaw_z)^T t_z,
//   theta = wrap(yaw_b - yaw_a - yaw_z),  e = [W(theta) d, theta],
//   W = V^-1 = [[a, b], [-b, a]] / (a^2 + b^2),
// the derivatives of the unwhitened error are
//   de/dt_a = [-W D; 0],  de/dt_b = [W D; 0],
//   de/dyaw_a = [W R(yaw_z)^T dR(yaw_a)^T/dyaw (t_b - t_a) - W' d; -1],
//   de/dyaw_b = [W' d; 1],
// where W' = dW/dtheta follows from a' = (theta cos - sin) / theta^2,
// b' = (theta sin - 1 + cos) / theta^2 (Taylor series near theta = 0).
// The residual and Jacobians are then multiplied by S.
class PoseError2dAnalytic : public ceres::SizedCostFunction<3, 3, 3> {
 public:
  PoseError2dAnalytic(const Eigen::Vector3d& measurement, const Eigen::Matrix3d& sqrt_information)
      : z_(measurement),
        cz_(std::cos(measurement(2))),
        sz_(std::sin(measurement(2))),
        sqrt_information_(sqrt_information) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const double* a = parameters[0];
    const double* b = parameters[1];
    const double dx = b[0] - a[0], dy = b[1] - a[1];
    const double ca = std::cos(a[2]), sa = std::sin(a[2]);
    const double tx = ca * dx + sa * dy, ty = -sa * dx + ca * dy;
    const double ux = tx - z_(0), uy = ty - z_(1);
    const double d_x = cz_ * ux + sz_ * uy, d_y = -sz_ * ux + cz_ * uy;
    const double theta = wrapAngleT(b[2] - a[2] - z_(2));

    double va, vb, da, db;  // V's a, b and their derivatives in theta
    if (std::abs(theta) < 1e-5) {
      const double t2 = theta * theta;
      va = 1.0 - t2 / 6.0;
      vb = theta / 2.0 - theta * t2 / 24.0;
      da = -theta / 3.0;
      db = 0.5 - t2 / 8.0;
    } else {
      const double s = std::sin(theta), c = std::cos(theta);
      va = s / theta;
      vb = (1.0 - c) / theta;
      da = (theta * c - s) / (theta * theta);
      db = (theta * s - 1.0 + c) / (theta * theta);
    }
    const double det = va * va + vb * vb;
    const double ddet = 2.0 * (va * da + vb * db);
    Eigen::Matrix2d w;
    w << va, vb, -vb, va;
    w /= det;
    Eigen::Matrix2d dw;
    dw << da, db, -db, da;
    dw = dw / det - (ddet / det) * w;

    const Eigen::Vector2d dvec(d_x, d_y);
    const Eigen::Vector3d e((w * dvec)(0), (w * dvec)(1), theta);
    Eigen::Map<Eigen::Vector3d> r(residuals);
    r = sqrt_information_ * e;
    if (jacobians == nullptr) return true;

    Eigen::Matrix2d rz_t, ra_t, dra_t;
    rz_t << cz_, sz_, -sz_, cz_;
    ra_t << ca, sa, -sa, ca;
    dra_t << -sa, ca, -ca, -sa;
    const Eigen::Matrix2d wd = w * rz_t * ra_t;
    const Eigen::Vector2d dw_d = dw * dvec;
    using RowMajor3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
    if (jacobians[0] != nullptr) {
      RowMajor3 j = RowMajor3::Zero();
      j.block<2, 2>(0, 0) = -wd;
      j.block<2, 1>(0, 2) = w * rz_t * dra_t * Eigen::Vector2d(dx, dy) - dw_d;
      j(2, 2) = -1.0;
      Eigen::Map<RowMajor3> out(jacobians[0]);
      out = sqrt_information_ * j;
    }
    if (jacobians[1] != nullptr) {
      RowMajor3 j = RowMajor3::Zero();
      j.block<2, 2>(0, 0) = wd;
      j.block<2, 1>(0, 2) = dw_d;
      j(2, 2) = 1.0;
      Eigen::Map<RowMajor3> out(jacobians[1]);
      out = sqrt_information_ * j;
    }
    return true;
  }

  EIGEN_MAKE_ALIGNED_OPERATOR_NEW

 private:
  Eigen::Vector3d z_;
  double cz_, sz_;
  Eigen::Matrix3d sqrt_information_;
};

inline ceres::CostFunction* PoseError2d::create(const Eigen::Vector3d& measurement,
                                                const Eigen::Matrix3d& sqrt_information) {
  return new PoseError2dAnalytic(measurement, sqrt_information);
}

}  // namespace core
}  // namespace agnc_pgo
