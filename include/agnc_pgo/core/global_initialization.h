// Global initialisation of a pose graph by linear least squares: an estimate
// that does not depend on composing the odometry, so a batch optimiser started
// from it does not inherit the odometry's drift (and the local minimum that
// drift can lead Levenberg-Marquardt into).
//
// SE(2), LAGO-style (Carlone et al., "A fast and accurate approximation for
// planar pose graph optimization", IJRR 2014):
//   1. orientations along a spanning tree (the odometry chain where it exists,
//      loop closures bridging its gaps);
//   2. each edge's angle constraint theta_j - theta_i = z_ij + 2*pi*k_ij, with
//      k_ij chosen so the constraint agrees with the tree to within
//      (-pi, pi] (the regularisation that makes the angle problem linear);
//   3. one sparse weighted linear least-squares solve of all angle constraints,
//      weighted by the marginal information of the measured angle;
//   4. positions by a second linear solve given the orientations:
//      t_j - t_i = R(theta_i) t_ij, weighted by the translation block of the
//      information rotated into the world frame.
// SE(3), chordal relaxation (Martinec & Pajdla, CVPR 2007; Carlone et al.,
// "Initialization techniques for 3D SLAM", ICRA 2015):
//   1. linear least squares on the 9 entries of every rotation matrix,
//      R_j = R_i R_ij, dropping the SO(3) constraint; edge weight: the mean
//      eigenvalue of the marginal rotation information;
//   2. projection of each 3x3 matrix onto SO(3) (SVD, det +1);
//   3. positions as in SE(2).
// Gauge: the graph's FIX poses (or pose 0) stay at their current values.
#pragma once

#include <vector>

#include "agnc_pgo/core/pose_graph.h"

namespace agnc_pgo {
namespace core {

struct GlobalInitializationOptions {
  bool skip_outliers = false;  // leave out edges labelled is_outlier (as BatchOptions)
};

// Returns one pose per id (max(poses.size(), largest edge id + 1) of them);
// does not modify the graph. Throws std::invalid_argument if a pose is not
// connected to the gauge by the edges used, or an id is negative.
std::vector<Pose, Eigen::aligned_allocator<Pose>> globalInitialization(
    const PoseGraph& graph, const GlobalInitializationOptions& options = GlobalInitializationOptions());

}  // namespace core
}  // namespace agnc_pgo
