// Accuracy metrics: loop-closure classification and trajectory errors.
#pragma once

#include <string>
#include <vector>

#include "agnc_pgo/core/pose_graph.h"
#include "agnc_pgo/core/trajectory_io.h"  // Poses, writeTumTrajectory

namespace agnc_pgo {
namespace core {

struct ClassificationCounts {
  int true_positive = 0;   // true loop kept
  int false_positive = 0;  // outlier kept
  int false_negative = 0;  // true loop rejected
  int true_negative = 0;   // outlier rejected
  double precision() const;  // 1 when nothing was kept
  double recall() const;     // 1 when there was nothing to keep
};

// is_outlier[k] is the ground-truth label, kept[k] the classification.
ClassificationCounts classify(const std::vector<bool>& is_outlier, const std::vector<bool>& kept);

// Rigid (no scale) least-squares alignment of `estimate` onto `reference`
// positions (Umeyama). Returns the RMSE of position error after alignment.
// Both must have the same length (throws std::invalid_argument otherwise).
double absoluteTrajectoryError(const Poses& estimate, const Poses& reference, int dimension);

// RMSE of the translational relative-pose error between consecutive poses.
double relativePoseError(const Poses& estimate, const Poses& reference);

}  // namespace core
}  // namespace agnc_pgo
