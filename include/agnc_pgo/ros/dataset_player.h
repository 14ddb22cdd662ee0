// The dataset player's data side (ROS-free): a g2o graph (with injected
// outliers) or an .irl log turned into the stream a front-end would publish:
// keyframe poses composed from odometry, and loop closures with labels.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "agnc_pgo/core/pose_graph.h"
#include "agnc_pgo/eval/outlier_injection.h"

namespace agnc_pgo {
namespace ros_backend {

struct PlayerEntry {
  enum class Type { kPose, kLoopClosure } type = Type::kPose;
  int pose = -1;                // kPose: the new pose id
  core::Pose odom_pose;         // kPose: composed odometry (pose 0 = the prior's value)
  Eigen::MatrixXd information;  // kPose: information of the odometry edge into it (pose 0: the prior's)
  core::Edge loop;              // kLoopClosure (is_outlier = ground truth)
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
};

struct PlayerDataset {
  std::string name;
  int dimension = 2;
  int poses = 0, loop_closures = 0, outliers = 0;
  std::vector<PlayerEntry, Eigen::aligned_allocator<PlayerEntry>> entries;
};

// Reads FILE.g2o (injecting `outlier_percent` % outliers with `seed`, placed
// as `outlier_mode` with `group_size` pairs per group, like agnc_pgo_replay)
// or FILE.irl (labelled outliers; outlier_percent must be 0 and the mode
// random) and orders it with core::logFromGraph. Throws on errors.
PlayerDataset loadPlayerDataset(const std::string& path, double outlier_percent, unsigned long seed,
                                core::OutlierMode outlier_mode = core::OutlierMode::kRandom,
                                int group_size = core::kDefaultGroupSize);

}  // namespace ros_backend
}  // namespace agnc_pgo
