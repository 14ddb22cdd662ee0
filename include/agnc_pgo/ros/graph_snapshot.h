// A copy of the back-end's graph and estimate, taken by the worker after an
// update and handed to the publishers (nothing in it refers to the engine).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <ros/time.h>

#include "agnc_pgo/core/incremental_gnc.h"
#include "agnc_pgo/core/pose.h"

namespace agnc_pgo {
namespace ros_backend {

struct SnapshotNode {
  ros::Time stamp;
  core::Pose pose;       // estimate (map frame)
  core::Pose odom_pose;  // odometry at the keyframe (odom frame)
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
};

enum class SnapshotEdgeType { kOdometry = 0, kLoopClosure = 1, kPrior = 2 };

struct SnapshotEdge {
  SnapshotEdgeType type = SnapshotEdgeType::kOdometry;
  int from = 0, to = 0;
  int loop_index = -1;
  core::Pose measurement;
  Eigen::MatrixXd information;  // core order
  double mu = 1.0, weight = 1.0, distance = 0.0;
  bool inlier = true;
  bool graduating = false;      // still graduating or not yet solved
  core::LoopOverride mode = core::LoopOverride::kAuto;
  std::string source;
  double score = 0.0;
  double test_distance = 0.0, threshold = 0.0;  // loop closures: what GNC compared
  bool uncorroborated = false, dormant = false;  // core::LoopClosure
  long decided_in_update = 0;
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
};

struct GraphSnapshot {
  int dimension = 2;
  ros::Time stamp;  // when taken
  std::vector<SnapshotNode, Eigen::aligned_allocator<SnapshotNode>> nodes;
  // Filled only when edges were requested: prior, odometry, loop closures.
  std::vector<SnapshotEdge, Eigen::aligned_allocator<SnapshotEdge>> edges;
  bool has_edges = false;
  core::Pose map_to_odom;
};

using GraphSnapshotPtr = std::shared_ptr<const GraphSnapshot>;

}  // namespace ros_backend
}  // namespace agnc_pgo
