// A trajectory (one pose per graph node) and its TUM text export, used by the
// engine's interface and by the ROS back-end's ~save_trajectory.
#pragma once

#include <string>
#include <vector>

#include "agnc_pgo/core/pose.h"  // Poses

namespace agnc_pgo {
namespace core {

// Writes "index tx ty tz qx qy qz qw" lines (TUM format, time = pose index
// unless `stamps` gives one stamp per pose).
void writeTumTrajectory(const Poses& poses, const std::string& path,
                        const std::vector<double>& stamps = {});

}  // namespace core
}  // namespace agnc_pgo
