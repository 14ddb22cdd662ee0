// Plain pose types for SE(2) and SE(3) and the few group operations the
// library needs. SE(2) poses are stored in the same type as SE(3) poses
// (z = 0, rotation about z) so that graphs, I/O and metrics need one code path;
// the solver keeps its own minimal parameter blocks.
#pragma once

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace agnc_pgo {
namespace core {

struct Pose {
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();

  static Pose fromSE2(double x, double y, double yaw);
  // R = Rz(rz) * Ry(ry) * Rx(rx) (the .irl / GTSAM Pose3 convention for x y z rx ry rz).
  static Pose fromXYZRPY(double x, double y, double z, double rx, double ry, double rz);
  static Pose identity() { return Pose(); }

  double yaw() const;
  // yaw() of a rotation about z: an angle fromSE2 turns back into exactly q
  // when there is one (within a few ulps of 2 atan2(z, w)).
  static double planarYaw(const Eigen::Quaterniond& q);
  Pose inverse() const;
  Pose operator*(const Pose& other) const;

  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
};

using Poses = std::vector<Pose, Eigen::aligned_allocator<Pose>>;

// Wraps an angle to (-pi, pi].
double wrapAngle(double angle);

// The 3- or 6-vector error of pose b relative to pose a w.r.t. a measured
// relative pose z (the pose of b in a's frame). SE(2): [dx dy dtheta];
// SE(3): [dx dy dz, 2*vec(dq)] -- the same convention as the cost functions.
Eigen::VectorXd relativePoseError(int dimension, const Pose& a, const Pose& b, const Pose& z);

}  // namespace core
}  // namespace agnc_pgo
