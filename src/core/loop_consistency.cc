#include "agnc_pgo/core/loop_consistency.h"

#include <cmath>
#include <cstdlib>

#include <Eigen/Cholesky>

namespace agnc_pgo {
namespace core {

bool areNeighbours(const Edge& a, const Edge& b, int radius) {
  const bool same = std::abs(a.from - b.from) <= radius && std::abs(a.to - b.to) <= radius;
  const bool reversed = std::abs(a.from - b.to) <= radius && std::abs(a.to - b.from) <= radius;
  return same || reversed;
}

double cycleDistance(int dimension, const Edge& a, const Edge& b,
                     const std::function<Pose(int)>& pose) {
  // Pair b's endpoints with a's: b runs the same way as a or reversed.
  const bool same_direction = std::abs(a.from - b.from) + std::abs(a.to - b.to) <=
                              std::abs(a.from - b.to) + std::abs(a.to - b.from);
  const int near_from = same_direction ? b.from : b.to;
  const int near_to = same_direction ? b.to : b.from;
  // The pose of near_to in the frame of near_from, predicted through a.
  const Pose predicted = (pose(near_from).inverse() * pose(a.from)) * a.measurement *
                         (pose(a.to).inverse() * pose(near_to));
  const Pose measured = same_direction ? b.measurement : b.measurement.inverse();
  const Eigen::VectorXd e = relativePoseError(dimension, Pose::identity(), predicted, measured);
  const Eigen::MatrixXd covariance = a.information.inverse() + b.information.inverse();
  return std::sqrt(e.dot(covariance.ldlt().solve(e)));
}

}  // namespace core
}  // namespace agnc_pgo
