#include "agnc_pgo/ros/loop_closure_matcher.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace agnc_pgo {
namespace ros_backend {

int LoopClosureMatcher::add(const ros::Time& stamp) {
  if (!stamps_.empty() && stamp <= stamps_.back())
    throw std::invalid_argument("keyframe stamps must increase");
  stamps_.push_back(stamp);
  return static_cast<int>(stamps_.size()) - 1;
}

LoopClosureMatcher::Match LoopClosureMatcher::match(const ros::Time& stamp) const {
  Match m;
  if (stamps_.empty()) {
    m.status = Status::kNotYet;
    return m;
  }
  const double t = stamp.toSec();
  if (t > stamps_.back().toSec() + tolerance_) {
    m.status = Status::kNotYet;
    return m;
  }
  // Nearest keyframe: the first stamp >= t or the one before it.
  const auto upper = std::lower_bound(stamps_.begin(), stamps_.end(), stamp);
  int best = -1;
  double best_gap = 0.0;
  for (auto it : {upper, upper == stamps_.begin() ? stamps_.end() : upper - 1}) {
    if (it == stamps_.end()) continue;
    const double gap = std::abs((*it - stamp).toSec());
    if (best < 0 || gap < best_gap) {
      best = static_cast<int>(it - stamps_.begin());
      best_gap = gap;
    }
  }
  if (best >= 0 && best_gap <= tolerance_) {
    m.status = Status::kFound;
    m.id = best;
  } else {
    m.status = Status::kUnknown;
  }
  return m;
}

}  // namespace ros_backend
}  // namespace agnc_pgo
