#include "agnc_pgo/core/pose.h"

#include "agnc_pgo/core/se2_logmap.h"

#include <cmath>
#include <limits>

namespace agnc_pgo {
namespace core {

Pose Pose::fromSE2(double x, double y, double yaw) {
  Pose pose;
  pose.translation = Eigen::Vector3d(x, y, 0.0);
  // Wrapping first keeps w >= 0, so equal headings (e.g. 6.28 and -0.003)
  // give bit-identical quaternions and SE(2) poses round-trip through text.
  pose.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(wrapAngle(yaw), Eigen::Vector3d::UnitZ()));
  return pose;
}

Pose Pose::fromXYZRPY(double x, double y, double z, double rx, double ry, double rz) {
  Pose pose;
  pose.translation = Eigen::Vector3d(x, y, z);
  pose.rotation = Eigen::AngleAxisd(rz, Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(ry, Eigen::Vector3d::UnitY()) *
                  Eigen::AngleAxisd(rx, Eigen::Vector3d::UnitX());
  pose.rotation.normalize();
  return pose;
}

double Pose::yaw() const {
  const Eigen::Quaterniond& q = rotation;
  if (q.x() == 0.0 && q.y() == 0.0) return planarYaw(q);
  // Z-Y-X Euler yaw of a general rotation.
  const double siny = 2.0 * (q.w() * q.z() + q.x() * q.y());
  const double cosy = 1.0 - 2.0 * (q.y() * q.y() + q.z() * q.z());
  return wrapAngle(std::atan2(siny, cosy));
}

namespace {

bool rebuildsExactly(const Eigen::Quaterniond& q, double angle) {
  return Pose::fromSE2(0.0, 0.0, angle).rotation.coeffs() == q.coeffs();
}

}  // namespace

// The heading of a rotation about z (every SE(2) pose), as the angle that
// fromSE2 turns back into exactly this quaternion when there is one: the one
// nearest 2 atan2(z, w) within a few ulps. So fromSE2(yaw()) is the identity on
// every rotation fromSE2 made, an angle survives pose -> angle -> pose (the
// engine's parameters) unchanged, and a saved graph loads and saves again
// identically. Plain 2 atan2(z, w) or the Euler formula drift by an ulp per
// round.
double Pose::planarYaw(const Eigen::Quaterniond& q) {
  const double estimate = wrapAngle(2.0 * std::atan2(q.z(), q.w()));
  double below = estimate;
  double above = estimate;
  for (int step = 0; step < 4; ++step) {
    if (rebuildsExactly(q, below)) return below;
    if (step > 0 && rebuildsExactly(q, above)) return above;
    below = std::nextafter(below, -std::numeric_limits<double>::infinity());
    above = std::nextafter(above, std::numeric_limits<double>::infinity());
  }
  return estimate;
}

Pose Pose::inverse() const {
  Pose inv;
  inv.rotation = rotation.conjugate();
  inv.translation = -(inv.rotation * translation);
  return inv;
}

Pose Pose::operator*(const Pose& other) const {
  Pose out;
  out.translation = translation + rotation * other.translation;
  // Renormalise so long odometry chains do not drift off the unit sphere.
  out.rotation = (rotation * other.rotation).normalized();
  return out;
}

double wrapAngle(double angle) {
  // Most angles are wrapped already, and there std::remainder returns them
  // unchanged (|angle / 2pi| <= 1/2 rounds to 0, ties to even); glibc's
  // remainder saves and restores the rounding mode, which made it a
  // twentieth of an update's time.
  if (angle > -M_PI && angle <= M_PI) return angle;
  // std::remainder maps to [-pi, pi]; move the closed lower end to +pi.
  double wrapped = std::remainder(angle, 2.0 * M_PI);
  if (wrapped <= -M_PI) wrapped += 2.0 * M_PI;
  return wrapped;
}

Eigen::VectorXd relativePoseError(int dimension, const Pose& a, const Pose& b, const Pose& z) {
  const Pose e = z.inverse() * (a.inverse() * b);
  if (dimension == 2) {
    Eigen::VectorXd r(3);
    se2Logmap(e.translation.x(), e.translation.y(), wrapAngle(b.yaw() - a.yaw() - z.yaw()), r.data());
    return r;
  }
  // q and -q are the same rotation; w >= 0 picks the small-angle
  // representative so the residual is continuous around zero.
  const double sign = e.rotation.w() < 0.0 ? -1.0 : 1.0;
  Eigen::VectorXd r(6);
  r.head<3>() = e.translation;
  r.tail<3>() = 2.0 * sign * e.rotation.vec();
  return r;
}

}  // namespace core
}  // namespace agnc_pgo
