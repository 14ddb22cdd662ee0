// Message <-> core conversions: poses (with SE(2) projection), covariances in
// REP 103 order (x y z roll pitch yaw, 6x6 row-major) <-> core information
// matrices in g2o order (2D: x y theta; 3D: x y z rx ry rz), and input checks.
#pragma once

#include <array>
#include <string>

#include <Eigen/Core>
#include <boost/array.hpp>
#include <geometry_msgs/Pose.h>

#include "agnc_pgo/core/pose.h"
#include "agnc_pgo/ros/backend_parameters.h"

namespace agnc_pgo {
namespace ros_backend {

using RosCovariance = boost::array<double, 36>;

// Index in the REP 103 6-vector of each component of the core tangent order.
// 2D: x y theta = REP x y yaw. 3D: x y z rx ry rz = REP x y z roll pitch yaw
// (small-angle rotation vector components about the same axes).
const std::vector<int>& rep103Indices(int dimension);

// Empty if the pose is usable, else why not (NaN/Inf, zero quaternion).
std::string checkPose(const geometry_msgs::Pose& pose);
// "" or why the position is implausible: a component beyond max_position [m]
// (1e308 is finite, but composing it cancels every other digit of the map).
std::string checkPosition(const geometry_msgs::Pose& pose, double max_position);
// "" or why an information matrix is implausible (an entry beyond max_information).
std::string checkInformation(const Eigen::MatrixXd& information, double max_information);
// Normalises the quaternion. Call checkPose first.
core::Pose fromMsg(const geometry_msgs::Pose& pose);
geometry_msgs::Pose toMsg(const core::Pose& pose);
// (x, y, yaw) of a 3D pose as a planar pose.
core::Pose projectToPlane(const core::Pose& pose);
// projectToPlane for dimension 2, identity for 3.
core::Pose toDimension(const core::Pose& pose, int dimension);

bool isZero(const RosCovariance& covariance);
// The information (inverse covariance) of the REP 103 covariance's block for
// `dimension`, in core order. Throws std::invalid_argument (NaN/Inf, not
// symmetric, not positive definite) with the reason.
Eigen::MatrixXd informationFromCovariance(const RosCovariance& covariance, int dimension);
// Inverse: a REP 103 covariance from a core information matrix; entries
// outside the dimension's block are 0.
RosCovariance covarianceFromInformation(const Eigen::MatrixXd& information, int dimension);
// Diagonal information from REP 103 standard deviations.
Eigen::MatrixXd informationFromSigmas(const Sigmas& sigmas, int dimension);
// Covariance (core order) of a core-order information matrix.
Eigen::MatrixXd covarianceOf(const Eigen::MatrixXd& information);

}  // namespace ros_backend
}  // namespace agnc_pgo
