// Saving and loading the back-end's graph: a g2o file (core writeG2o/readG2o:
// estimate, prior-free edges, FIX 0) plus a sidecar FILE.meta with what g2o
// cannot hold (keyframe stamps and odometry poses, the prior, the edge kinds,
// each loop closure's graduation state, override, stamps, source, score).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <ros/time.h>

#include "agnc_pgo/core/incremental_gnc.h"
#include "agnc_pgo/core/pose_graph.h"

namespace agnc_pgo {
namespace ros_backend {

struct SavedLoop {
  core::Edge edge;
  core::LoopClosureState state;  // graduation, override, the engine's flags
  ros::Time from_stamp, to_stamp;
  std::string source;
  double score = 0.0;
};

struct SavedGraph {
  int dimension = 2;
  core::Pose prior_value;
  Eigen::MatrixXd prior_information;
  std::vector<ros::Time> stamps;  // one per node
  core::Poses odom_poses;         // one per node
  core::Poses estimate;           // one per node
  std::vector<core::Edge> odometry;
  std::vector<SavedLoop> loops;
  bool has_state = true;          // false: plain g2o without sidecar (loop states unknown)
};

std::string sidecarPath(const std::string& g2o_path);

// Throws std::runtime_error (with the file and reason) on failure.
void saveGraph(const SavedGraph& graph, const std::string& g2o_path);
// Reads FILE and FILE.meta. Without a sidecar, the g2o file alone is loaded:
// stamps 1 s, 2 s, ... (synthetic), odometry poses = the estimate, edges
// classified by |i - j|, has_state = false, prior from `default_prior_information`.
SavedGraph loadGraph(const std::string& g2o_path, const Eigen::MatrixXd& default_prior_information);

}  // namespace ros_backend
}  // namespace agnc_pgo
