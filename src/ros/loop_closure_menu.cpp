#include "agnc_pgo/ros/loop_closure_menu.h"

#include <visualization_msgs/InteractiveMarkerControl.h>

#include "agnc_pgo/SetLoopClosureStatus.h"

namespace agnc_pgo {
namespace ros_backend {
namespace {
const std::string kPrefix = "loop_closure_";
}

int modeOfMenuEntry(unsigned entry) {
  switch (entry) {
    case kMenuForceInlier: return agnc_pgo::SetLoopClosureStatus::Request::FORCE_INLIER;
    case kMenuForceOutlier: return agnc_pgo::SetLoopClosureStatus::Request::FORCE_OUTLIER;
    case kMenuAutomatic: return agnc_pgo::SetLoopClosureStatus::Request::AUTO;
    default: return -1;
  }
}

std::string markerName(int loop_index) { return kPrefix + std::to_string(loop_index); }

int loopIndexOf(const std::string& marker_name) {
  if (marker_name.compare(0, kPrefix.size(), kPrefix) != 0 || marker_name.size() == kPrefix.size()) return -1;
  const std::string digits = marker_name.substr(kPrefix.size());
  if (digits.find_first_not_of("0123456789") != std::string::npos || digits.size() > 9) return -1;
  return std::stoi(digits);
}

visualization_msgs::InteractiveMarker loopClosureMarker(const agnc_pgo::PoseGraph& graph,
                                                        const agnc_pgo::PoseGraphEdge& edge, double scale) {
  visualization_msgs::InteractiveMarker m;
  m.header.frame_id = graph.header.frame_id;
  m.name = markerName(edge.loop_index);
  const auto& a = graph.nodes.at(edge.from_id).pose.position;
  const auto& b = graph.nodes.at(edge.to_id).pose.position;
  m.pose.position.x = 0.5 * (a.x + b.x);
  m.pose.position.y = 0.5 * (a.y + b.y);
  m.pose.position.z = 0.5 * (a.z + b.z);
  m.pose.orientation.w = 1.0;
  m.scale = static_cast<float>(scale);
  const char* state = edge.graduating ? "graduating" : edge.inlier ? "inlier" : "outlier";
  m.description = "loop closure " + std::to_string(edge.loop_index) + " (" + std::to_string(edge.from_id) + " - " +
                  std::to_string(edge.to_id) + "): " + state;

  visualization_msgs::Marker sphere;
  sphere.type = visualization_msgs::Marker::SPHERE;
  sphere.scale.x = sphere.scale.y = sphere.scale.z = scale;
  sphere.color.a = 0.8f;
  if (edge.graduating) sphere.color.b = 1.0f;
  else if (edge.inlier) sphere.color.g = 0.8f;
  else sphere.color.r = 1.0f;
  visualization_msgs::InteractiveMarkerControl control;
  control.name = "menu";
  control.interaction_mode = visualization_msgs::InteractiveMarkerControl::MENU;
  control.always_visible = true;
  control.markers.push_back(sphere);
  m.controls.push_back(control);
  return m;
}

}  // namespace ros_backend
}  // namespace agnc_pgo
