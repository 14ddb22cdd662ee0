#include "agnc_pgo/core/loop_consistency.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

#include <Eigen/Cholesky>

namespace agnc_pgo {
namespace core {

bool areNeighbours(const Edge& a, const Edge& b, int radius) {
  const bool same = std::abs(a.from - b.from) <= radius && std::abs(a.to - b.to) <= radius;
  const bool reversed = std::abs(a.from - b.to) <= radius && std::abs(a.to - b.from) <= radius;
  return same || reversed;
}

namespace {

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

// The adjoint of x for right perturbations in the library's tangent order:
// x Exp(d) = Exp(Ad(x) d) x. SE(3), [t; rotation]: [[R, [t]x R], [0, R]];
// SE(2), [x y theta]: its rows and columns x, y, yaw.
Eigen::MatrixXd adjoint(int dimension, const Pose& x) {
  const Eigen::Matrix3d r = x.rotation.toRotationMatrix();
  Eigen::Matrix<double, 6, 6> ad = Eigen::Matrix<double, 6, 6>::Zero();
  ad.topLeftCorner<3, 3>() = r;
  ad.topRightCorner<3, 3>() = skew(x.translation) * r;
  ad.bottomRightCorner<3, 3>() = r;
  if (dimension == 3) return ad;
  const int planar[3] = {0, 1, 5};
  Eigen::Matrix3d ad2;
  for (int row = 0; row < 3; ++row)
    for (int col = 0; col < 3; ++col) ad2(row, col) = ad(planar[row], planar[col]);
  return ad2;
}

// Sigma carried through Ad(x): the covariance of x d x^-1 for d ~ Sigma.
Eigen::MatrixXd carried(int dimension, const Pose& x, const Eigen::MatrixXd& sigma) {
  const Eigen::MatrixXd ad = adjoint(dimension, x);
  return ad * sigma * ad.transpose();
}

}  // namespace

bool segmentCovariance(int dimension, int i, int j, const std::function<Pose(int)>& pose,
                       const StepCovariance& step, Eigen::MatrixXd* covariance) {
  const int n = dimension == 2 ? 3 : 6;
  const int low = std::min(i, j), high = std::max(i, j);
  // C = T_low^-1 T_p grows one step at a time: C' = C o, o = T_(p-1)^-1 T_p,
  // and a perturbation of C becomes o^-1 d o.
  Eigen::MatrixXd sigma = Eigen::MatrixXd::Zero(n, n);
  Pose chain;
  for (int p = low + 1; p <= high; ++p) {
    const Eigen::MatrixXd step_sigma = step(p);
    if (step_sigma.rows() != n) return false;
    const Pose o = pose(p - 1).inverse() * pose(p);
    sigma = carried(dimension, o.inverse(), sigma) + step_sigma;
    chain = chain * o;
  }
  // T_high^-1 T_low = C^-1, and (C d)^-1 = C^-1 (C d^-1 C^-1).
  *covariance = i <= j ? sigma : carried(dimension, chain, sigma);
  return true;
}

double cycleDistance(int dimension, const Edge& a, const Edge& b, const std::function<Pose(int)>& pose,
                     const StepCovariance& step, double variance_factor) {
  Eigen::VectorXd e;
  Eigen::MatrixXd covariance;
  if (!cycleError(dimension, a, b, pose, step, &e, &covariance)) return std::numeric_limits<double>::infinity();
  return std::sqrt(e.dot(covariance.ldlt().solve(e)) / variance_factor);
}

bool cycleError(int dimension, const Edge& a, const Edge& b, const std::function<Pose(int)>& pose,
                const StepCovariance& step, Eigen::VectorXd* error, Eigen::MatrixXd* covariance) {
  // Pair b's endpoints with a's: b runs the same way as a or reversed.
  const bool same_direction = std::abs(a.from - b.from) + std::abs(a.to - b.to) <=
                              std::abs(a.from - b.to) + std::abs(a.to - b.from);
  const int near_from = same_direction ? b.from : b.to;
  const int near_to = same_direction ? b.to : b.from;
  Eigen::MatrixXd sigma_from, sigma_to;
  if (!segmentCovariance(dimension, near_from, a.from, pose, step, &sigma_from) ||
      !segmentCovariance(dimension, a.to, near_to, pose, step, &sigma_to))
    return false;
  // The pose of near_to in the frame of near_from, predicted through a.
  const Pose segment_from = pose(near_from).inverse() * pose(a.from);
  const Pose segment_to = pose(a.to).inverse() * pose(near_to);
  const Pose predicted = segment_from * a.measurement * segment_to;
  const Pose measured = same_direction ? b.measurement : b.measurement.inverse();
  *error = relativePoseError(dimension, Pose::identity(), predicted, measured);
  const Eigen::MatrixXd sigma_b = b.information.inverse();
  *covariance = carried(dimension, (a.measurement * segment_to).inverse(), sigma_from) +
                carried(dimension, segment_to.inverse(), a.information.inverse()) + sigma_to +
                (same_direction ? sigma_b : carried(dimension, b.measurement, sigma_b));
  return true;
}

}  // namespace core
}  // namespace agnc_pgo
