// Whether the map explains a far loop closure better than chance does.
//
// A loop closure far off by its own covariance is either true -- the
// trajectory between its endpoints drifted -- or false. The map says which
// is likelier. If it is true, its whitened residual r is the drift, with the
// covariance S = I + J H^-1 J^T that the map's uncertainty between the
// endpoints gives it (SparsePoseGraphSolver::predict):
//
//   p(r | true)  = N(r; 0, S)
//
// If it is false, the front-end matched two arbitrary places: r is then
// anywhere the map reaches, about uniformly over the relative poses it
// holds -- translations within the extent of its positions, rotations
// within the extent of its orientations (all headings for a car that turned
// around, but hardly any roll or pitch) -- whose volume in whitened
// coordinates is V = sqrt(det Omega) * V_physical:
//
//   p(r | false) = 1 / V
//
// The loop closure is worth landing when the likelihood ratio
// N(r; 0, S) * V exceeds 1 (even prior odds). The ratio is what a gate on
// r^T S^-1 r alone misses: where the map is uncertain (an open trajectory
// after a long drive), S is so wide that any residual looks plausible, but
// then its density is no higher than chance, and the test holds the loop
// closure back; where the map is certain a true loop closure is far more
// likely than chance even many sigma off by its own covariance.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "agnc_pgo/core/pose.h"
#include "agnc_pgo/core/pose_manifolds.h"

namespace agnc_pgo {
namespace core {

// log V: the whitened volume of the relative poses of a map whose poses
// span `extent` (mapExtent), for a factor of this information (3x3 or 6x6,
// translation first). Each axis spans at least one standard deviation of
// the factor.
double logChanceVolume(const Eigen::VectorXd& extent, const Eigen::MatrixXd& information);

// The k-th time the map judges the same loop closure (k >= 1), the odds it
// must beat: log k. A loop closure judged again (the map has tightened, or a
// landing has moved it) gets another chance to look explained; a likelihood
// ratio exceeds k under the false hypothesis with probability at most 1/k
// (Markov's inequality: its mean there is 1), so the k-th judgement asks
// for a ratio above k -- the bar of a repeated test (Bonferroni's), not a
// tuned one. The first keeps even odds. Throws std::invalid_argument for
// k < 1.
double repeatedJudgementLogOdds(int judgement);

// log(N(r; 0, S) * V). -inf if S is not finite and positive definite.
double logPredictionOdds(const Eigen::VectorXd& residual, const Eigen::MatrixXd& covariance,
                         double log_chance_volume);

// An upper bound on logPredictionOdds(residual, S, log V) over every S
// with floor * I <= S <= ceiling: the Mahalanobis distance is at least the
// one under the ceiling, the log-determinant at least d log floor. +inf if
// the ceiling is not finite and positive definite.
double logPredictionOddsBound(const Eigen::VectorXd& residual, const Eigen::MatrixXd& ceiling, double floor,
                              double log_chance_volume);

// The extent of the poses in the factor's tangent order: per axis, max -
// min of the positions; then the arc that holds every heading (SE(2)), or
// of roll, pitch and yaw (SE(3); roll and yaw on the circle, pitch on
// [-pi/2, pi/2]).
Eigen::VectorXd mapExtent(int dimension, const Poses& poses);
// The same over the solver's parameter blocks (pose_manifolds.h), which
// hold the heading of an SE(2) pose as it is: no conversion per pose.
Eigen::VectorXd mapExtent(int dimension, const std::vector<PoseBlock>& blocks);

// The shortest arc of the circle that holds every angle (0 for none).
double circularExtent(std::vector<double> angles);

}  // namespace core
}  // namespace agnc_pgo
