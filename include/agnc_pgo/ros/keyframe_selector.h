// Decides which odometry messages become keyframes (translation, rotation and
// time thresholds) and rejects stamps that do not increase.
#pragma once

#include <ros/time.h>

#include "agnc_pgo/core/pose.h"
#include "agnc_pgo/ros/backend_parameters.h"

namespace agnc_pgo {
namespace ros_backend {

class KeyframeSelector {
 public:
  enum class Decision { kKeyframe, kSkip, kStampNotIncreasing };

  explicit KeyframeSelector(const KeyframeParameters& parameters) : parameters_(parameters) {}

  // Classifies the message and, unless rejected, remembers it (and, for a
  // keyframe, makes it the reference for the next decision).
  Decision consider(const ros::Time& stamp, const core::Pose& odom_pose);

  // Makes (stamp, pose) the last keyframe (after loading a graph).
  void resetTo(const ros::Time& stamp, const core::Pose& odom_pose);
  void clear() { has_keyframe_ = false; last_stamp_ = ros::Time(); }

  const ros::Time& lastStamp() const { return last_stamp_; }

 private:
  KeyframeParameters parameters_;
  bool has_keyframe_ = false;
  ros::Time last_stamp_;  // last accepted message (keyframe or not)
  ros::Time keyframe_stamp_;
  core::Pose keyframe_pose_;
};

}  // namespace ros_backend
}  // namespace agnc_pgo
