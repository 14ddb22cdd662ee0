// Maps stamps to keyframes: the nearest keyframe within a tolerance.
#pragma once

#include <vector>

#include <ros/time.h>

namespace agnc_pgo {
namespace ros_backend {

class LoopClosureMatcher {
 public:
  enum class Status { kFound, kNotYet, kUnknown };
  struct Match {
    Status status = Status::kUnknown;
    int id = -1;
  };

  explicit LoopClosureMatcher(double tolerance) : tolerance_(tolerance) {}

  // Keyframe stamps must strictly increase; returns the new keyframe's id.
  int add(const ros::Time& stamp);
  void clear() { stamps_.clear(); }
  // For later matches (dynamic_reconfigure ~stamp_tolerance).
  void setTolerance(double tolerance) { tolerance_ = tolerance; }
  // kFound: nearest keyframe within the tolerance. kNotYet: newer than the
  // latest keyframe by more than the tolerance (it may still arrive).
  // kUnknown: within the keyframes' span but matches none (or no keyframe
  // is older than it).
  Match match(const ros::Time& stamp) const;

  int size() const { return static_cast<int>(stamps_.size()); }
  const ros::Time& stamp(int id) const { return stamps_[id]; }
  const std::vector<ros::Time>& stamps() const { return stamps_; }

 private:
  double tolerance_;
  std::vector<ros::Time> stamps_;
};

}  // namespace ros_backend
}  // namespace agnc_pgo
