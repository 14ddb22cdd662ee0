#include "agnc_pgo/ros/graph_io.h"

#include <sstream>
#include <stdexcept>
#include <sys/stat.h>

#include "agnc_pgo/core/atomic_file.h"
#include "agnc_pgo/core/g2o_io.h"
#include "agnc_pgo/ros/graph_sidecar.h"

namespace agnc_pgo {
namespace ros_backend {
namespace {

constexpr std::size_t kMaxFileBytes = std::size_t(1) << 31;  // 2 GiB: far above any real map

bool exists(const std::string& path) {
  struct stat info;
  return ::stat(path.c_str(), &info) == 0;
}

SidecarStamp toSidecar(const ros::Time& t) { return {t.sec, t.nsec}; }
ros::Time fromSidecar(const SidecarStamp& s) { return ros::Time(s.sec, s.nsec); }

Sidecar sidecarOf(const SavedGraph& g) {
  Sidecar s;
  s.dimension = g.dimension;
  s.prior_value = g.prior_value;
  s.prior_information = g.prior_information;
  for (const ros::Time& t : g.stamps) s.stamps.push_back(toSidecar(t));
  s.odom_poses = g.odom_poses;
  s.odometry_edges = g.odometry.size();
  for (const SavedLoop& l : g.loops) {
    SidecarLoop out;
    out.from = l.edge.from;
    out.to = l.edge.to;
    out.state = l.state;
    out.from_stamp = toSidecar(l.from_stamp);
    out.to_stamp = toSidecar(l.to_stamp);
    out.source = l.source;
    out.score = l.score;
    out.is_outlier = l.edge.is_outlier;
    s.loops.push_back(out);
  }
  return s;
}

SavedGraph plainG2o(const core::PoseGraph& graph, const Eigen::MatrixXd& default_prior_information) {
  SavedGraph g;
  g.dimension = graph.dimension;
  g.estimate = graph.poses;
  g.has_state = false;
  g.prior_value = graph.poses[0];
  g.prior_information = default_prior_information;
  for (size_t i = 0; i < graph.poses.size(); ++i) g.stamps.emplace_back(1.0 + static_cast<double>(i));
  g.odom_poses = graph.poses;
  for (const core::Edge& e : graph.edges) {
    if (e.kind == core::EdgeKind::kOdometry && e.to == e.from + 1) {
      g.odometry.push_back(e);
    } else {
      SavedLoop l;
      l.edge = e;
      l.from_stamp = g.stamps[e.from];
      l.to_stamp = g.stamps[e.to];
      l.source = "g2o";
      g.loops.push_back(l);
    }
  }
  return g;
}

SavedGraph combine(const core::PoseGraph& graph, const Sidecar& s) {
  SavedGraph g;
  g.dimension = graph.dimension;
  g.estimate = graph.poses;
  g.prior_value = s.prior_value;
  g.prior_information = s.prior_information;
  for (const SidecarStamp& t : s.stamps) g.stamps.push_back(fromSidecar(t));
  g.odom_poses = s.odom_poses;
  for (size_t k = 0; k < s.odometry_edges; ++k) {
    core::Edge e = graph.edges[k];
    e.kind = core::EdgeKind::kOdometry;
    g.odometry.push_back(e);
  }
  for (size_t k = 0; k < s.loops.size(); ++k) {
    const SidecarLoop& in = s.loops[k];
    SavedLoop l;
    l.edge = graph.edges[s.odometry_edges + k];
    l.edge.kind = core::EdgeKind::kLoopClosure;
    l.edge.is_outlier = in.is_outlier;
    l.state = in.state;
    l.from_stamp = fromSidecar(in.from_stamp);
    l.to_stamp = fromSidecar(in.to_stamp);
    l.source = in.source;
    l.score = in.score;
    g.loops.push_back(l);
  }
  return g;
}

// The sidecar that belongs to the g2o bytes: FILE.meta, or the staged one a
// save killed between its two renames left behind (its g2o is already in
// place, so the new pair is complete). Throws if neither matches.
Sidecar matchingSidecar(const std::string& path, const std::string& g2o_text, const core::PoseGraph& graph) {
  const std::string meta = sidecarPath(path);
  std::string reason;
  for (const std::string& candidate : {meta, core::stagingPath(meta)}) {
    if (!exists(candidate)) continue;
    const Sidecar s = parseSidecar(core::readWholeFile(candidate, kMaxFileBytes), candidate);
    const std::string mismatch = sidecarMismatch(s, g2o_text, graph);
    if (mismatch.empty()) return s;
    if (reason.empty()) reason = candidate + " does not belong to " + path + ": " + mismatch;
  }
  throw std::runtime_error(reason + " (the pair was not saved together; remove " + meta + " to load " + path +
                           " without its state)");
}

}  // namespace

std::string sidecarPath(const std::string& g2o_path) { return g2o_path + ".meta"; }

void saveGraph(const SavedGraph& g, const std::string& path) {
  const size_t n = g.estimate.size();
  if (g.stamps.size() != n || g.odom_poses.size() != n)
    throw std::runtime_error("inconsistent graph (stamps/poses)");
  core::PoseGraph graph;
  graph.dimension = g.dimension;
  graph.poses = g.estimate;
  graph.fixed = {0};
  for (const core::Edge& e : g.odometry) graph.edges.push_back(e);
  for (const SavedLoop& l : g.loops) graph.edges.push_back(l.edge);
  std::ostringstream g2o;
  core::writeG2o(graph, g2o);  // throws for non-finite values
  const std::string g2o_text = g2o.str();
  const std::string meta_text = formatSidecar(sidecarOf(g), g2o_text);

  // Both files complete on disk before either replaces its old version; a
  // kill between the two renames leaves FILE new and FILE.meta.saving new,
  // which loadGraph pairs by checksum.
  const std::string meta = sidecarPath(path);
  core::stageFile(path, g2o_text);
  core::stageFile(meta, meta_text);
  core::commitStagedFile(path);
  core::commitStagedFile(meta);
}

SavedGraph loadGraph(const std::string& path, const Eigen::MatrixXd& default_prior_information) {
  const std::string g2o_text = core::readWholeFile(path, kMaxFileBytes);
  std::istringstream in(g2o_text);
  const core::PoseGraph graph = core::readG2o(in, path);  // throws ParseError naming file:line
  if (graph.poses.empty()) throw std::runtime_error(path + ": no poses");
  const std::string meta = sidecarPath(path);
  if (!exists(meta) && !exists(core::stagingPath(meta))) return plainG2o(graph, default_prior_information);
  return combine(graph, matchingSidecar(path, g2o_text, graph));
}

}  // namespace ros_backend
}  // namespace agnc_pgo
