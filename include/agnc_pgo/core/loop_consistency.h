// Pairwise consistency of two loop closures (the test of PCM, Mangelson et
// al. 2018, restricted to neighbouring loop closures).
//
// Two loop closures a (fa -> ta, z_a) and b (fb -> tb, z_b) whose endpoints
// lie close to each other along the trajectory predict each other through
// the short trajectory segments between their endpoints:
//
//   z_b ~ A z_a B,   A = T_fb^-1 T_fa,   B = T_ta^-1 T_tb
//
// The segments come from the current estimate; over a few poses they are
// as good as the odometry, whatever the drift of the map, so the test holds
// for true loop closures that the map does not yet agree with (a ring closed
// after a long drift) and fails for random false ones. The cycle error
// e = Log(z_b^-1 A z_a B) is whitened with the covariance of everything in
// the cycle, each term carried to e's frame to first order (right
// perturbations, Ad = the adjoint):
//
//   Sigma_e = Ad(z_a B)^-1 Sigma_A Ad(z_a B)^-T + Ad(B)^-1 Sigma_a Ad(B)^-T + Sigma_B + Sigma_b
//
// where Sigma_A and Sigma_B are the odometry's uncertainty accumulated along
// the segments. Without them the test would call two true loop closures
// inconsistent whenever a few odometry steps are as uncertain as a loop
// closure (a car's scan-matched odometry). A reversed pair (fa near tb, ta
// near fb) uses z_b^-1.
#pragma once

#include <functional>

#include <Eigen/Core>

#include "agnc_pgo/core/pose.h"
#include "agnc_pgo/core/pose_graph.h"

namespace agnc_pgo {
namespace core {

// Whether the endpoints of a and b are pairwise within `radius` poses
// (either orientation), i.e. whether cycleDistance() applies.
bool areNeighbours(const Edge& a, const Edge& b, int radius);

// The covariance of the odometry step that created pose p from pose p - 1
// (of its measurement, as a right perturbation), or an empty matrix if pose
// p was not created by odometry from p - 1 (the start of a chain).
using StepCovariance = std::function<Eigen::MatrixXd(int p)>;

// The covariance of T_i^-1 T_j accumulated along the odometry chain between
// i and j (either order), carried through the estimate `pose`; false if the
// chain is broken between them.
bool segmentCovariance(int dimension, int i, int j, const std::function<Pose(int)>& pose,
                       const StepCovariance& step, Eigen::MatrixXd* covariance);

// The whitened norm of the cycle error (see above); `pose(id)` returns the
// current estimate of a pose. Meaningful for neighbours (areNeighbours());
// infinite if a segment is not an odometry chain (the two loop closures
// cannot vouch for each other across a gap). The stated covariances are
// scaled by `variance_factor`, the a-posteriori variance of unit weight
// (SparsePoseGraphSolver::varianceFactor): graphs that state their noise
// many times too wide would otherwise let arbitrary pairs agree.
double cycleDistance(int dimension, const Edge& a, const Edge& b, const std::function<Pose(int)>& pose,
                     const StepCovariance& step, double variance_factor = 1.0);

// The cycle error e and its covariance (above), with the stated
// covariances; false if a segment is not an odometry chain.
bool cycleError(int dimension, const Edge& a, const Edge& b, const std::function<Pose(int)>& pose,
                const StepCovariance& step, Eigen::VectorXd* error, Eigen::MatrixXd* covariance);

}  // namespace core
}  // namespace agnc_pgo
