// Right-click overrides in rviz's 3-D view: one interactive marker per loop
// closure (a sphere at its midpoint, coloured by state) with the menu
// "Force inlier / Force outlier / Automatic", as slam_toolbox's interactive
// mode does for its nodes. The node loop_closure_menu serves them from
// ~pose_graph; these are its message-building pieces.
#pragma once

#include <string>

#include <visualization_msgs/InteractiveMarker.h>

#include "agnc_pgo/PoseGraph.h"

namespace agnc_pgo {
namespace ros_backend {

// Menu entry ids in insertion order (interactive_markers::MenuHandler
// numbers them from 1), and the SetLoopClosureStatus mode each one sets.
constexpr unsigned kMenuForceInlier = 1, kMenuForceOutlier = 2, kMenuAutomatic = 3;
int modeOfMenuEntry(unsigned entry);  // -1 for an unknown entry

std::string markerName(int loop_index);           // "loop_closure_12"
int loopIndexOf(const std::string& marker_name);  // -1 if not such a name

// The marker for loop-closure edge `edge` of `graph` (frame: the graph's).
visualization_msgs::InteractiveMarker loopClosureMarker(const agnc_pgo::PoseGraph& graph,
                                                        const agnc_pgo::PoseGraphEdge& edge, double scale);

}  // namespace ros_backend
}  // namespace agnc_pgo
