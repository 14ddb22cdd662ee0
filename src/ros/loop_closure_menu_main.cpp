// loop_closure_menu: serves one interactive marker per loop closure of the
// back-end's ~pose_graph (topic namespace ~, i.e. /loop_closure_menu/update
// for rviz's InteractiveMarkers display) whose right-click menu forces the
// loop closure to be an inlier or an outlier or hands it back to GNC,
// through ~set_loop_closure_status. Parameters: ~backend (default
// /agnc_pgo_backend), ~marker_scale [m] (default 0.6).
#include <map>
#include <memory>
#include <tuple>

#include <interactive_markers/interactive_marker_server.h>
#include <interactive_markers/menu_handler.h>
#include <ros/ros.h>

#include "agnc_pgo/PoseGraph.h"
#include "agnc_pgo/ros/loop_closure_menu.h"
#include "agnc_pgo/rviz/backend_commands.h"

namespace agnc_pgo {
namespace ros_backend {
namespace {

class LoopClosureMenu {
 public:
  LoopClosureMenu(ros::NodeHandle& pnh, const std::string& backend, double scale)
      : server_("loop_closure_menu", "", false), commands_(backend), scale_(scale) {
    using interactive_markers::MenuHandler;
    const auto feedback = [this](const visualization_msgs::InteractiveMarkerFeedbackConstPtr& f) { onMenu(f); };
    menu_.insert("Force inlier", feedback);
    menu_.insert("Force outlier", feedback);
    menu_.insert("Automatic (GNC decides)", feedback);
    subscriber_ = pnh.subscribe(backend + "/pose_graph", 1, &LoopClosureMenu::onGraph, this);
  }

 private:
  using Key = std::tuple<double, double, double, bool, bool>;  // midpoint and state: re-sent when changed

  void onGraph(const agnc_pgo::PoseGraph::ConstPtr& graph) {
    std::map<int, Key> seen;
    for (const auto& e : graph->edges) {
      if (e.type != agnc_pgo::PoseGraphEdge::LOOP_CLOSURE || e.from_id >= graph->nodes.size() ||
          e.to_id >= graph->nodes.size())
        continue;
      const visualization_msgs::InteractiveMarker marker = loopClosureMarker(*graph, e, scale_);
      const Key key{marker.pose.position.x, marker.pose.position.y, marker.pose.position.z, e.inlier, e.graduating};
      seen[e.loop_index] = key;
      const auto previous = sent_.find(e.loop_index);
      if (previous != sent_.end() && previous->second == key) continue;
      server_.insert(marker);
      menu_.apply(server_, marker.name);
    }
    for (const auto& [index, key] : sent_)
      if (!seen.count(index)) server_.erase(markerName(index));
    sent_ = std::move(seen);
    server_.applyChanges();
  }

  void onMenu(const visualization_msgs::InteractiveMarkerFeedbackConstPtr& feedback) {
    const int index = loopIndexOf(feedback->marker_name);
    const int mode = modeOfMenuEntry(feedback->menu_entry_id);
    if (index < 0 || mode < 0) return;
    const agnc_pgo::panel::CommandOutcome outcome = commands_.setOverride(index, mode);
    if (outcome.success) ROS_INFO_STREAM("loop_closure_menu: " << outcome.message);
    else ROS_WARN_STREAM("loop_closure_menu: " << outcome.message);
  }

  interactive_markers::InteractiveMarkerServer server_;
  interactive_markers::MenuHandler menu_;
  agnc_pgo::panel::BackendCommands commands_;
  double scale_;
  ros::Subscriber subscriber_;
  std::map<int, Key> sent_;
};

}  // namespace
}  // namespace ros_backend
}  // namespace agnc_pgo

int main(int argc, char** argv) {
  ros::init(argc, argv, "loop_closure_menu");
  ros::NodeHandle pnh("~");
  std::string backend = "/agnc_pgo_backend";
  double scale = 0.6;
  pnh.getParam("backend", backend);
  pnh.getParam("marker_scale", scale);
  if (!(scale > 0)) {
    ROS_FATAL("loop_closure_menu: ~marker_scale must be > 0");
    return 1;
  }
  agnc_pgo::ros_backend::LoopClosureMenu menu(pnh, backend, scale);
  // Feedback callbacks call the back-end's service: a second thread keeps
  // the graph subscription going meanwhile.
  ros::AsyncSpinner spinner(2);
  spinner.start();
  ros::waitForShutdown();
  return 0;
}
