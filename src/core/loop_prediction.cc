#include "agnc_pgo/core/loop_prediction.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Cholesky>

namespace agnc_pgo {
namespace core {

double logChanceVolume(const Eigen::VectorXd& extent, const Eigen::MatrixXd& information) {
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(information);
  const Eigen::MatrixXd covariance = ldlt.solve(Eigen::MatrixXd::Identity(information.rows(), information.cols()));
  // sqrt(det Omega): the whitening of the physical volume.
  double log_volume = 0.5 * ldlt.vectorD().array().log().sum();
  for (int k = 0; k < extent.size(); ++k) log_volume += std::log(std::max(extent(k), std::sqrt(covariance(k, k))));
  return log_volume;
}

double logPredictionOdds(const Eigen::VectorXd& residual, const Eigen::MatrixXd& covariance,
                         double log_chance_volume) {
  if (!covariance.allFinite()) return -std::numeric_limits<double>::infinity();
  const Eigen::LLT<Eigen::MatrixXd> llt(covariance);
  if (llt.info() != Eigen::Success) return -std::numeric_limits<double>::infinity();
  const double mahalanobis2 = llt.matrixL().solve(residual).squaredNorm();
  const double log_det = 2.0 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum();
  const double d = static_cast<double>(residual.size());
  return log_chance_volume - 0.5 * (mahalanobis2 + log_det + d * std::log(2.0 * M_PI));
}

double logPredictionOddsBound(const Eigen::VectorXd& residual, const Eigen::MatrixXd& ceiling, double floor,
                              double log_chance_volume) {
  if (!ceiling.allFinite() || !(floor > 0.0)) return std::numeric_limits<double>::infinity();
  const Eigen::LLT<Eigen::MatrixXd> llt(ceiling);
  if (llt.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
  const double mahalanobis2 = llt.matrixL().solve(residual).squaredNorm();
  const double d = static_cast<double>(residual.size());
  return log_chance_volume - 0.5 * (mahalanobis2 + d * std::log(floor) + d * std::log(2.0 * M_PI));
}

double circularExtent(std::vector<double> angles) {
  if (angles.empty()) return 0.0;
  for (double& a : angles) a = std::remainder(a, 2.0 * M_PI);
  std::sort(angles.begin(), angles.end());
  // The arc is the circle less its largest gap between neighbouring angles.
  double gap = angles.front() + 2.0 * M_PI - angles.back();
  for (size_t k = 1; k < angles.size(); ++k) gap = std::max(gap, angles[k] - angles[k - 1]);
  return 2.0 * M_PI - gap;
}

Eigen::VectorXd mapExtent(int dimension, const Poses& poses) {
  const int tangent = dimension == 2 ? 3 : 6;
  Eigen::VectorXd extent = Eigen::VectorXd::Zero(tangent);
  if (poses.empty()) return extent;
  Eigen::VectorXd low = Eigen::VectorXd::Constant(dimension, std::numeric_limits<double>::infinity());
  Eigen::VectorXd high = -low;
  std::vector<std::vector<double>> angles(dimension == 2 ? 1 : 3);
  double pitch_low = M_PI, pitch_high = -M_PI;
  for (const Pose& p : poses) {
    low = low.cwiseMin(p.translation.head(dimension));
    high = high.cwiseMax(p.translation.head(dimension));
    if (dimension == 2) {
      angles[0].push_back(p.yaw());
      continue;
    }
    // Z-Y-X angles: R = Rz(yaw) Ry(pitch) Rx(roll), pitch in [-pi/2, pi/2].
    const Eigen::Matrix3d r = p.rotation.toRotationMatrix();
    const double yaw = std::atan2(r(1, 0), r(0, 0));
    const double pitch = std::asin(std::max(-1.0, std::min(1.0, -r(2, 0))));
    const double roll = std::atan2(r(2, 1), r(2, 2));
    angles[0].push_back(roll);
    pitch_low = std::min(pitch_low, pitch);
    pitch_high = std::max(pitch_high, pitch);
    angles[2].push_back(yaw);
  }
  extent.head(dimension) = high - low;
  if (dimension == 2) {
    extent(2) = circularExtent(angles[0]);
  } else {
    extent(3) = circularExtent(angles[0]);
    extent(4) = pitch_high - pitch_low;
    extent(5) = circularExtent(angles[2]);
  }
  return extent;
}

}  // namespace core
}  // namespace agnc_pgo
