#include "agnc_pgo/core/pose_graph.h"

#include <algorithm>
#include <cstdlib>
#include <stdexcept>
#include <string>

namespace agnc_pgo {
namespace core {

int PoseGraph::numLoopClosures() const {
  return static_cast<int>(std::count_if(edges.begin(), edges.end(), [](const Edge& e) {
    return e.kind == EdgeKind::kLoopClosure;
  }));
}

int PoseGraph::numOutliers() const {
  return static_cast<int>(std::count_if(edges.begin(), edges.end(), [](const Edge& e) {
    return e.kind == EdgeKind::kLoopClosure && e.is_outlier;
  }));
}

EdgeKind classifyEdge(int from, int to) {
  return std::abs(from - to) == 1 ? EdgeKind::kOdometry : EdgeKind::kLoopClosure;
}

namespace {

// Index of the first odometry edge joining k and k+1 (either direction), per k.
std::vector<int> odometryLinks(const PoseGraph& graph, int num_poses) {
  std::vector<int> link(std::max(num_poses - 1, 0), -1);
  for (int i = 0; i < static_cast<int>(graph.edges.size()); ++i) {
    const Edge& e = graph.edges[i];
    if (e.kind != EdgeKind::kOdometry || std::abs(e.from - e.to) != 1) continue;
    const int k = std::min(e.from, e.to);
    if (k >= 0 && k < static_cast<int>(link.size()) && link[k] < 0) link[k] = i;
  }
  return link;
}

}  // namespace

void initializeFromOdometry(PoseGraph* graph) {
  int num_poses = static_cast<int>(graph->poses.size());
  for (const Edge& e : graph->edges) num_poses = std::max({num_poses, e.from + 1, e.to + 1});
  graph->poses.resize(num_poses);  // new poses start at the identity

  const std::vector<int> link = odometryLinks(*graph, num_poses);
  for (int k = 0; k + 1 < num_poses; ++k) {
    if (link[k] < 0) continue;  // a new odometry chain keeps its own start
    const Edge& e = graph->edges[link[k]];
    // An edge written k+1 -> k measures pose k in the frame of k+1.
    const Pose step = e.from == k ? e.measurement : e.measurement.inverse();
    graph->poses[k + 1] = graph->poses[k] * step;
  }
}

}  // namespace core
}  // namespace agnc_pgo
