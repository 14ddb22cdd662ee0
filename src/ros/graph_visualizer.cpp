#include "agnc_pgo/ros/graph_visualizer.h"

#include <algorithm>

#include "agnc_pgo/ros/conversions.h"

namespace agnc_pgo {
namespace ros_backend {

const char* const kNodesNamespace = "nodes";
const char* const kOdometryNamespace = "odometry";
const char* const kInlierNamespace = "loop_inliers";
const char* const kOutlierNamespace = "loop_outliers";
const char* const kGraduatingNamespace = "loop_graduating";
const char* const kStatusNamespace = "status";

namespace {

std_msgs::ColorRGBA color(float r, float g, float b, float a = 1.0f) {
  std_msgs::ColorRGBA c;
  c.r = r;
  c.g = g;
  c.b = b;
  c.a = a;
  return c;
}

geometry_msgs::Point point(const core::Pose& p) {
  geometry_msgs::Point out;
  out.x = p.translation.x();
  out.y = p.translation.y();
  out.z = p.translation.z();
  return out;
}

visualization_msgs::Marker lineList(const std::string& ns, int id, const VisualizerStyle& style, double width,
                                    const std_msgs::ColorRGBA& c, const ros::Time& stamp) {
  visualization_msgs::Marker m;
  m.header.frame_id = style.frame;
  m.header.stamp = stamp;
  m.ns = ns;
  m.id = id;
  m.type = visualization_msgs::Marker::LINE_LIST;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1.0;
  m.scale.x = width;
  m.color = c;
  return m;
}

visualization_msgs::Marker nodeMarker(const GraphSnapshot& snapshot, const VisualizerStyle& style) {
  visualization_msgs::Marker nodes;
  nodes.header.frame_id = style.frame;
  nodes.ns = kNodesNamespace;
  nodes.type = visualization_msgs::Marker::POINTS;
  nodes.action = visualization_msgs::Marker::ADD;
  nodes.pose.orientation.w = 1.0;
  nodes.scale.x = nodes.scale.y = style.node_scale;
  nodes.color = color(0.2f, 0.4f, 1.0f);
  for (const SnapshotNode& n : snapshot.nodes) nodes.points.push_back(point(n.pose));
  return nodes;
}

// One line list per kind of edge.
struct EdgeMarkers {
  visualization_msgs::Marker odometry, inliers, outliers, graduating;
};

void addEdges(const GraphSnapshot& snapshot, EdgeMarkers* markers) {
  for (const SnapshotEdge& e : snapshot.edges) {
    if (e.type == SnapshotEdgeType::kPrior) continue;
    const geometry_msgs::Point a = point(snapshot.nodes[e.from].pose), b = point(snapshot.nodes[e.to].pose);
    visualization_msgs::Marker* target = &markers->odometry;
    if (e.type == SnapshotEdgeType::kLoopClosure)
      target = e.graduating ? &markers->graduating : (e.inlier ? &markers->inliers : &markers->outliers);
    target->points.push_back(a);
    target->points.push_back(b);
    if (target == &markers->graduating) {
      // Shaded by weight: 1 -> yellow-green, 0 -> orange-red.
      const float w = static_cast<float>(std::min(1.0, std::max(0.0, e.weight)));
      const std_msgs::ColorRGBA c = color(1.0f, 0.3f + 0.6f * w, 0.0f, 0.9f);
      markers->graduating.colors.push_back(c);
      markers->graduating.colors.push_back(c);
    }
  }
}

// The counts, above the graph's bounding box.
visualization_msgs::Marker statusText(const GraphSnapshot& snapshot, const VisualizerStyle& style,
                                      const EdgeMarkers& edges) {
  visualization_msgs::Marker text;
  text.header.frame_id = style.frame;
  text.ns = kStatusNamespace;
  text.type = visualization_msgs::Marker::TEXT_VIEW_FACING;
  text.action = visualization_msgs::Marker::ADD;
  text.pose.orientation.w = 1.0;
  text.color = color(0.0f, 0.0f, 0.0f);
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (const SnapshotNode& n : snapshot.nodes) {
    lo = lo.cwiseMin(n.pose.translation);
    hi = hi.cwiseMax(n.pose.translation);
  }
  if (snapshot.nodes.empty()) lo = hi = Eigen::Vector3d::Zero();
  const double size = std::max(5.0, (hi - lo).head<2>().maxCoeff());
  text.scale.z = 0.04 * size;
  text.pose.position.x = 0.5 * (lo.x() + hi.x());
  text.pose.position.y = hi.y() + 0.06 * size;
  text.pose.position.z = hi.z();
  const size_t inliers = edges.inliers.points.size() / 2, outliers = edges.outliers.points.size() / 2,
               graduating = edges.graduating.points.size() / 2;
  text.text = std::to_string(snapshot.nodes.size()) + " nodes | " + std::to_string(inliers + outliers + graduating) +
              " loop closures: " + std::to_string(inliers) + " inliers (green), " + std::to_string(outliers) +
              " outliers (red), " + std::to_string(graduating) + " graduating";
  return text;
}

}  // namespace

nav_msgs::Path makePath(const GraphSnapshot& snapshot, const std::string& frame) {
  nav_msgs::Path path;
  path.header.frame_id = frame;
  path.header.stamp = snapshot.nodes.empty() ? ros::Time() : snapshot.nodes.back().stamp;
  path.poses.resize(snapshot.nodes.size());
  for (size_t i = 0; i < snapshot.nodes.size(); ++i) {
    path.poses[i].header.frame_id = frame;
    path.poses[i].header.stamp = snapshot.nodes[i].stamp;
    path.poses[i].pose = toMsg(snapshot.nodes[i].pose);
  }
  return path;
}

visualization_msgs::MarkerArray makeMarkers(const GraphSnapshot& snapshot, const VisualizerStyle& style) {
  const ros::Time stamp;  // time 0: rviz uses the latest transform
  visualization_msgs::Marker nodes = nodeMarker(snapshot, style);
  EdgeMarkers edges{
      lineList(kOdometryNamespace, 0, style, style.line_width * 0.5, color(0.6f, 0.6f, 0.6f, 0.8f), stamp),
      lineList(kInlierNamespace, 0, style, style.line_width, color(0.0f, 0.8f, 0.0f, 0.8f), stamp),
      lineList(kOutlierNamespace, 0, style, style.line_width * 1.5, color(1.0f, 0.0f, 0.0f, 0.9f), stamp),
      lineList(kGraduatingNamespace, 0, style, style.line_width, color(1.0f, 0.8f, 0.0f), stamp)};
  addEdges(snapshot, &edges);
  visualization_msgs::MarkerArray array;
  array.markers.push_back(statusText(snapshot, style, edges));
  for (visualization_msgs::Marker* m : {&nodes, &edges.odometry, &edges.inliers, &edges.outliers, &edges.graduating}) {
    // An empty LINE_LIST is not drawn: DELETE keeps rviz from showing stale lines.
    if (m->points.empty()) m->action = visualization_msgs::Marker::DELETE;
    array.markers.push_back(*m);
  }
  return array;
}

agnc_pgo::PoseGraph makePoseGraph(const GraphSnapshot& snapshot, const std::string& frame) {
  agnc_pgo::PoseGraph msg;
  msg.header.frame_id = frame;
  msg.header.stamp = ros::Time::now();
  msg.dimension = static_cast<uint8_t>(snapshot.dimension);
  msg.nodes.resize(snapshot.nodes.size());
  for (size_t i = 0; i < snapshot.nodes.size(); ++i) {
    msg.nodes[i].id = static_cast<uint32_t>(i);
    msg.nodes[i].stamp = snapshot.nodes[i].stamp;
    msg.nodes[i].pose = toMsg(snapshot.nodes[i].pose);
    msg.nodes[i].odom_pose = toMsg(snapshot.nodes[i].odom_pose);
  }
  msg.edges.resize(snapshot.edges.size());
  for (size_t k = 0; k < snapshot.edges.size(); ++k) {
    const SnapshotEdge& e = snapshot.edges[k];
    agnc_pgo::PoseGraphEdge& out = msg.edges[k];
    out.type = static_cast<uint8_t>(e.type);
    out.from_id = static_cast<uint32_t>(e.from);
    out.to_id = static_cast<uint32_t>(e.to);
    out.loop_index = e.loop_index;
    out.relative_pose = toMsg(e.measurement);
    out.covariance = covarianceFromInformation(e.information, snapshot.dimension);
    out.mu = e.mu;
    out.weight = e.weight;
    out.distance = e.distance;
    out.inlier = e.inlier;
    out.graduating = e.graduating;
    out.mode = static_cast<uint8_t>(e.mode);
    out.source = e.source;
    out.score = e.score;
    out.test_distance = e.test_distance;
    out.threshold = e.threshold;
    out.uncorroborated = e.uncorroborated;
    out.dormant = e.dormant;
    out.decided_in_update = static_cast<uint32_t>(e.decided_in_update);
  }
  return msg;
}

agnc_pgo::GraphStatus makeStatus(const StatusInfo& s) {
  agnc_pgo::GraphStatus msg;
  msg.header.stamp = ros::Time::now();
  msg.nodes = s.nodes;
  msg.odometry_edges = s.odometry_edges;
  msg.loop_closures = s.loop_closures;
  msg.inliers = s.inliers;
  msg.outliers = s.outliers;
  msg.graduating = s.graduating;
  msg.held_loop_closures = s.held;
  msg.odometry_messages = s.counters.odometry_messages;
  msg.loop_closure_messages = s.counters.loop_closure_messages;
  msg.rejected_odometry = s.counters.rejected_odometry;
  msg.rejected_loop_closures = s.counters.rejected_loop_closures;
  msg.dropped_loop_closures = s.counters.dropped_loop_closures;
  msg.failed_updates = s.counters.failed_updates;
  msg.last_update = s.last_update;
  msg.last_gnc_steps = s.counters.last_gnc_steps;
  msg.total_gnc_steps = static_cast<uint64_t>(s.total_gnc_steps);
  msg.total_iterations = static_cast<uint64_t>(s.total_iterations);
  msg.last_update_ms = s.counters.last_update_ms;
  msg.latency_ms_p50 = s.latency_p50;
  msg.latency_ms_p95 = s.latency_p95;
  msg.latency_ms_max = s.latency_max;
  msg.first_estimate_latency_ms_p50 = s.first_latency_p50;
  msg.first_estimate_latency_ms_p95 = s.first_latency_p95;
  msg.first_estimate_latency_ms_max = s.first_latency_max;
  msg.first_estimates = s.counters.first_estimates;
  msg.idle_refinements = s.counters.idle_refinements;
  msg.refining = s.refining;
  msg.noise_scale_translation = s.noise_scale_translation;
  msg.noise_scale_rotation = s.noise_scale_rotation;
  msg.paused = s.paused;
  msg.last_warning = s.counters.last_warning;
  return msg;
}

}  // namespace ros_backend
}  // namespace agnc_pgo
