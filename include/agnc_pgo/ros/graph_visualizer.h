// Snapshot -> messages: ~path, ~markers (nodes, odometry, loop closures by
// state in separate namespaces), ~pose_graph and ~status.
#pragma once

#include <string>

#include <nav_msgs/Path.h>
#include <visualization_msgs/MarkerArray.h>

#include "agnc_pgo/GraphStatus.h"
#include "agnc_pgo/PoseGraph.h"
#include "agnc_pgo/ros/backend_worker.h"
#include "agnc_pgo/ros/graph_snapshot.h"

namespace agnc_pgo {
namespace ros_backend {

struct VisualizerStyle {
  std::string frame = "map";
  double node_scale = 0.15;
  double line_width = 0.05;
};

// Marker namespaces.
extern const char* const kNodesNamespace;          // "nodes"
extern const char* const kOdometryNamespace;       // "odometry"
extern const char* const kInlierNamespace;         // "loop_inliers"   (green)
extern const char* const kOutlierNamespace;        // "loop_outliers"  (red)
extern const char* const kGraduatingNamespace;     // "loop_graduating" (shaded by weight)
extern const char* const kStatusNamespace;         // "status" (text above the graph)

nav_msgs::Path makePath(const GraphSnapshot& snapshot, const std::string& frame);
// One LINE_LIST per loop-closure namespace (2 points per loop closure).
visualization_msgs::MarkerArray makeMarkers(const GraphSnapshot& snapshot, const VisualizerStyle& style);
agnc_pgo::PoseGraph makePoseGraph(const GraphSnapshot& snapshot, const std::string& frame);
agnc_pgo::GraphStatus makeStatus(const StatusInfo& status);

}  // namespace ros_backend
}  // namespace agnc_pgo
