#include "agnc_pgo/ros/keyframe_selector.h"

#include <cmath>

namespace agnc_pgo {
namespace ros_backend {

KeyframeSelector::Decision KeyframeSelector::consider(const ros::Time& stamp, const core::Pose& odom_pose) {
  if (!last_stamp_.isZero() && stamp <= last_stamp_) return Decision::kStampNotIncreasing;
  last_stamp_ = stamp;
  bool keyframe = !has_keyframe_;
  const KeyframeParameters& p = parameters_;
  if (!keyframe) {
    const bool any_criterion = p.translation > 0 || p.rotation > 0 || p.interval > 0;
    if (!any_criterion) {
      keyframe = true;
    } else {
      const core::Pose delta = keyframe_pose_.inverse() * odom_pose;
      const double angle = Eigen::AngleAxisd(delta.rotation).angle();
      keyframe = (p.translation > 0 && delta.translation.norm() >= p.translation) ||
                 (p.rotation > 0 && std::abs(angle) >= p.rotation) ||
                 (p.interval > 0 && (stamp - keyframe_stamp_).toSec() >= p.interval);
    }
  }
  if (keyframe) resetTo(stamp, odom_pose);
  return keyframe ? Decision::kKeyframe : Decision::kSkip;
}

void KeyframeSelector::resetTo(const ros::Time& stamp, const core::Pose& odom_pose) {
  has_keyframe_ = true;
  keyframe_stamp_ = stamp;
  keyframe_pose_ = odom_pose;
  if (last_stamp_ < stamp) last_stamp_ = stamp;
}

}  // namespace ros_backend
}  // namespace agnc_pgo
