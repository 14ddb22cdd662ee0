// The SE(2) logarithm: the tangent vector [rho_x, rho_y, theta] of the
// relative pose (t, theta), as GTSAM's Pose2::Logmap computes it (the
// reference implementations' Local()).
//
//   theta = wrap(angle),  rho = V(theta)^-1 t,
//   V(theta) = [[A, -B], [B, A]],  A = sin(theta) / theta,  B = (1 - cos(theta)) / theta
//
// Templated so that the same maths serves plain doubles and Ceres Jets.
#pragma once

#include <cmath>

namespace agnc_pgo {
namespace core {

template <typename T>
void se2Logmap(const T& tx, const T& ty, const T& theta, T* out) {
  using std::abs;
  using std::cos;
  using std::sin;
  T a, b;
  if (abs(theta) < T(1e-5)) {
    // Taylor series; exact to double precision at this size.
    const T t2 = theta * theta;
    a = T(1.0) - t2 / T(6.0);
    b = theta / T(2.0) - theta * t2 / T(24.0);
  } else {
    a = sin(theta) / theta;
    b = (T(1.0) - cos(theta)) / theta;
  }
  const T det = a * a + b * b;
  out[0] = (a * tx + b * ty) / det;
  out[1] = (-b * tx + a * ty) / det;
  out[2] = theta;
}

}  // namespace core
}  // namespace agnc_pgo
