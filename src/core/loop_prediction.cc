#include "agnc_pgo/core/loop_prediction.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

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

double repeatedJudgementLogOdds(int judgement) {
  if (judgement < 1) throw std::invalid_argument("repeatedJudgementLogOdds: judgement " + std::to_string(judgement));
  return std::log(static_cast<double>(judgement));
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
  double low = std::numeric_limits<double>::infinity(), high = -low;
  for (double& a : angles) {
    // remainder() returns an angle already in [-pi, pi] exactly as it is.
    if (!(std::abs(a) <= M_PI)) a = std::remainder(a, 2.0 * M_PI);
    low = std::min(low, a);
    high = std::max(high, a);
  }
  // The arc is the circle less its largest gap between neighbouring angles,
  // found without sorting (the maximum-gap problem): between the lowest and
  // the highest of n angles the largest gap is at least (high - low) /
  // (n - 1), wider than each of n equal buckets, so it runs from the
  // highest angle of a non-empty bucket to the lowest of the next.
  double gap = low + 2.0 * M_PI - high;
  const size_t buckets = angles.size();
  if (buckets > 1 && high > low) {
    const double width = (high - low) / static_cast<double>(buckets);
    std::vector<double> bucket_low(buckets, std::numeric_limits<double>::infinity());
    std::vector<double> bucket_high(buckets, -std::numeric_limits<double>::infinity());
    for (double a : angles) {
      const size_t k = std::min(buckets - 1, static_cast<size_t>((a - low) / width));
      bucket_low[k] = std::min(bucket_low[k], a);
      bucket_high[k] = std::max(bucket_high[k], a);
    }
    double previous = bucket_high[0];
    for (size_t k = 1; k < buckets; ++k) {
      if (bucket_low[k] > bucket_high[k]) continue;  // empty
      gap = std::max(gap, bucket_low[k] - previous);
      previous = bucket_high[k];
    }
  }
  return 2.0 * M_PI - gap;
}

Eigen::VectorXd mapExtent(int dimension, const Poses& poses) {
  std::vector<PoseBlock> blocks;
  blocks.reserve(poses.size());
  for (const Pose& p : poses) blocks.push_back(toBlock(dimension, p));
  return mapExtent(dimension, blocks);
}

Eigen::VectorXd mapExtent(int dimension, const std::vector<PoseBlock>& blocks) {
  const int tangent = dimension == 2 ? 3 : 6;
  Eigen::VectorXd extent = Eigen::VectorXd::Zero(tangent);
  if (blocks.empty()) return extent;
  Eigen::VectorXd low = Eigen::VectorXd::Constant(dimension, std::numeric_limits<double>::infinity());
  Eigen::VectorXd high = -low;
  std::vector<std::vector<double>> angles(dimension == 2 ? 1 : 3);  // heading; roll, -, yaw
  angles[0].reserve(blocks.size());
  if (dimension == 3) angles[2].reserve(blocks.size());
  double pitch_low = M_PI, pitch_high = -M_PI;
  for (const PoseBlock& b : blocks) {
    const Eigen::Map<const Eigen::VectorXd> position(b.data(), dimension);
    low = low.cwiseMin(position);
    high = high.cwiseMax(position);
    if (dimension == 2) {
      angles[0].push_back(b[2]);
      continue;
    }
    // Z-Y-X angles: R = Rz(yaw) Ry(pitch) Rx(roll), pitch in [-pi/2, pi/2].
    const Eigen::Matrix3d r = Eigen::Quaterniond(b[6], b[3], b[4], b[5]).normalized().toRotationMatrix();
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
    extent(2) = circularExtent(std::move(angles[0]));
  } else {
    extent(3) = circularExtent(std::move(angles[0]));
    extent(4) = pitch_high - pitch_low;
    extent(5) = circularExtent(std::move(angles[2]));
  }
  return extent;
}

}  // namespace core
}  // namespace agnc_pgo
