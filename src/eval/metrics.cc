// Accuracy metrics (ALGORITHM.md §5): precision/recall over loop closures,
// ATE after rigid alignment, RPE between consecutive poses.
#include "agnc_pgo/eval/metrics.h"

#include <cmath>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <limits>
#include <stdexcept>

#include <Eigen/Geometry>

#include "agnc_pgo/core/atomic_file.h"

namespace agnc_pgo {
namespace core {

double ClassificationCounts::precision() const {
  const int kept = true_positive + false_positive;
  // Keeping nothing makes no false claim, so precision is perfect by convention.
  return kept == 0 ? 1.0 : static_cast<double>(true_positive) / kept;
}

double ClassificationCounts::recall() const {
  const int to_keep = true_positive + false_negative;
  // With no true loop there is nothing to miss.
  return to_keep == 0 ? 1.0 : static_cast<double>(true_positive) / to_keep;
}

ClassificationCounts classify(const std::vector<bool>& is_outlier, const std::vector<bool>& kept) {
  if (is_outlier.size() != kept.size()) {
    throw std::invalid_argument("classify: " + std::to_string(is_outlier.size()) + " labels but " +
                                std::to_string(kept.size()) + " decisions");
  }
  ClassificationCounts counts;
  for (std::size_t k = 0; k < kept.size(); ++k) {
    if (is_outlier[k]) {
      (kept[k] ? counts.false_positive : counts.true_negative) += 1;
    } else {
      (kept[k] ? counts.true_positive : counts.false_negative) += 1;
    }
  }
  return counts;
}

namespace {

// Positions as a dimension x N matrix; SE(2) poses live in the plane, so only
// x and y are used there (z would add a degenerate axis to the alignment).
Eigen::MatrixXd positionMatrix(const Poses& poses, int dimension) {
  Eigen::MatrixXd positions(dimension, static_cast<Eigen::Index>(poses.size()));
  for (std::size_t k = 0; k < poses.size(); ++k) {
    positions.col(static_cast<Eigen::Index>(k)) = poses[k].translation.head(dimension);
  }
  return positions;
}

void checkSameLength(const Poses& estimate, const Poses& reference, const char* who) {
  if (estimate.size() != reference.size()) {
    throw std::invalid_argument(std::string(who) + ": estimate has " + std::to_string(estimate.size()) +
                                " poses, reference " + std::to_string(reference.size()));
  }
}

}  // namespace

double absoluteTrajectoryError(const Poses& estimate, const Poses& reference, int dimension) {
  checkSameLength(estimate, reference, "absoluteTrajectoryError");
  if (dimension != 2 && dimension != 3) {
    throw std::invalid_argument("absoluteTrajectoryError: dimension must be 2 or 3");
  }
  if (estimate.empty()) {
    throw std::invalid_argument("absoluteTrajectoryError: empty trajectory");
  }
  const Eigen::MatrixXd src = positionMatrix(estimate, dimension);
  const Eigen::MatrixXd dst = positionMatrix(reference, dimension);
  // with_scaling = false: the benchmark aligns rigidly (SE(2)/SE(3)), a scale
  // factor would hide a shrunken or stretched estimate.
  const Eigen::MatrixXd transform = Eigen::umeyama(src, dst, false);
  const Eigen::MatrixXd rotation = transform.topLeftCorner(dimension, dimension);
  const Eigen::VectorXd shift = transform.topRightCorner(dimension, 1);
  const Eigen::MatrixXd aligned = (rotation * src).colwise() + shift;
  const double squared_sum = (aligned - dst).colwise().squaredNorm().sum();
  return std::sqrt(squared_sum / static_cast<double>(estimate.size()));
}

double relativePoseError(const Poses& estimate, const Poses& reference) {
  checkSameLength(estimate, reference, "relativePoseError");
  // Fewer than two poses have no consecutive pair, hence no relative error.
  if (estimate.size() < 2) return 0.0;
  double squared_sum = 0.0;
  for (std::size_t k = 0; k + 1 < estimate.size(); ++k) {
    const Pose reference_step = reference[k].inverse() * reference[k + 1];
    const Pose estimate_step = estimate[k].inverse() * estimate[k + 1];
    squared_sum += (reference_step.inverse() * estimate_step).translation.squaredNorm();
  }
  return std::sqrt(squared_sum / static_cast<double>(estimate.size() - 1));
}

}  // namespace core
}  // namespace agnc_pgo
