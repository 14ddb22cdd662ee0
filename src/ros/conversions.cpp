#include "agnc_pgo/ros/conversions.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Cholesky>
#include <Eigen/LU>

namespace agnc_pgo {
namespace ros_backend {

const std::vector<int>& rep103Indices(int dimension) {
  static const std::vector<int> planar{0, 1, 5};            // x y yaw
  static const std::vector<int> spatial{0, 1, 2, 3, 4, 5};  // x y z roll pitch yaw
  if (dimension != 2 && dimension != 3) throw std::invalid_argument("dimension must be 2 or 3");
  return dimension == 2 ? planar : spatial;
}

std::string checkPose(const geometry_msgs::Pose& pose) {
  const auto& p = pose.position;
  const auto& q = pose.orientation;
  if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) return "position contains NaN/Inf";
  if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z) || !std::isfinite(q.w))
    return "orientation contains NaN/Inf";
  const double norm = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
  if (norm < 1e-6) return "zero quaternion";
  if (std::abs(norm - 1.0) > 0.1) return "quaternion not normalised (norm " + std::to_string(norm) + ")";
  return "";
}

std::string checkPosition(const geometry_msgs::Pose& pose, double max_position) {
  const auto& p = pose.position;
  const double largest = std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)});
  if (!(largest <= max_position))
    return "implausible position component " + std::to_string(largest) + " m (limit ~max_position " +
           std::to_string(max_position) + " m)";
  return "";
}

std::string checkInformation(const Eigen::MatrixXd& information, double max_information) {
  const double largest = information.size() > 0 ? information.cwiseAbs().maxCoeff() : 0.0;
  if (!(largest <= max_information))
    return "implausible information entry " + std::to_string(largest) + " (covariance too small; limit ~max_information " +
           std::to_string(max_information) + ")";
  return "";
}

core::Pose fromMsg(const geometry_msgs::Pose& pose) {
  core::Pose out;
  out.translation = Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z);
  out.rotation = Eigen::Quaterniond(pose.orientation.w, pose.orientation.x, pose.orientation.y,
                                    pose.orientation.z).normalized();
  return out;
}

geometry_msgs::Pose toMsg(const core::Pose& pose) {
  geometry_msgs::Pose out;
  out.position.x = pose.translation.x();
  out.position.y = pose.translation.y();
  out.position.z = pose.translation.z();
  out.orientation.x = pose.rotation.x();
  out.orientation.y = pose.rotation.y();
  out.orientation.z = pose.rotation.z();
  out.orientation.w = pose.rotation.w();
  return out;
}

core::Pose projectToPlane(const core::Pose& pose) {
  return core::Pose::fromSE2(pose.translation.x(), pose.translation.y(), pose.yaw());
}

core::Pose toDimension(const core::Pose& pose, int dimension) {
  return dimension == 2 ? projectToPlane(pose) : pose;
}

bool isZero(const RosCovariance& covariance) {
  for (double v : covariance)
    if (v != 0.0) return false;
  return true;
}

Eigen::MatrixXd informationFromCovariance(const RosCovariance& covariance, int dimension) {
  const std::vector<int>& index = rep103Indices(dimension);
  const int n = static_cast<int>(index.size());
  Eigen::MatrixXd sigma(n, n);
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) sigma(r, c) = covariance[6 * index[r] + index[c]];
  if (!sigma.allFinite()) throw std::invalid_argument("covariance contains NaN/Inf");
  const double scale = sigma.cwiseAbs().maxCoeff();
  if ((sigma - sigma.transpose()).cwiseAbs().maxCoeff() > 1e-9 * std::max(scale, 1e-300))
    throw std::invalid_argument("covariance is not symmetric");
  Eigen::LLT<Eigen::MatrixXd> llt(sigma);
  if (llt.info() != Eigen::Success || sigma.diagonal().minCoeff() <= 0.0)
    throw std::invalid_argument("covariance is not positive definite");
  Eigen::MatrixXd information = llt.solve(Eigen::MatrixXd::Identity(n, n));
  information = 0.5 * (information + information.transpose());
  if (!information.allFinite()) throw std::invalid_argument("covariance is singular");
  Eigen::LLT<Eigen::MatrixXd> check(information);
  if (check.info() != Eigen::Success) throw std::invalid_argument("covariance is not positive definite");
  return information;
}

Eigen::MatrixXd covarianceOf(const Eigen::MatrixXd& information) {
  Eigen::MatrixXd cov = information.ldlt().solve(Eigen::MatrixXd::Identity(information.rows(), information.cols()));
  return 0.5 * (cov + cov.transpose());
}

RosCovariance covarianceFromInformation(const Eigen::MatrixXd& information, int dimension) {
  const std::vector<int>& index = rep103Indices(dimension);
  const int n = static_cast<int>(index.size());
  if (information.rows() != n || information.cols() != n)
    throw std::invalid_argument("information must be " + std::to_string(n) + "x" + std::to_string(n));
  const Eigen::MatrixXd sigma = covarianceOf(information);
  RosCovariance out;
  out.fill(0.0);
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) out[6 * index[r] + index[c]] = sigma(r, c);
  return out;
}

Eigen::MatrixXd informationFromSigmas(const Sigmas& sigmas, int dimension) {
  const std::vector<int>& index = rep103Indices(dimension);
  const int n = static_cast<int>(index.size());
  Eigen::MatrixXd information = Eigen::MatrixXd::Zero(n, n);
  for (int i = 0; i < n; ++i) information(i, i) = 1.0 / (sigmas[index[i]] * sigmas[index[i]]);
  return information;
}

}  // namespace ros_backend
}  // namespace agnc_pgo
