#include "agnc_pgo/eval/incremental_log.h"

#include <algorithm>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/LU>

namespace agnc_pgo {
namespace core {

namespace {

// Information of the prior that anchors pose 0 of a replayed g2o graph: tight
// enough to act as a gauge fix, loose enough to keep the system well scaled.
constexpr double kPriorInformation = 1e8;
// The start of a later odometry chain: sigma 1000 (m, rad), only a gauge
// until a loop closure ties the chain to the others.
constexpr double kChainPriorInformation = 1e-6;

// Adjoint of `pose` in the residual's tangent order (translation first):
// SE(2) [[R, (y, -x)], [0, 1]]; SE(3) [[R, [t]x R], [0, R]].
Eigen::MatrixXd adjoint(int dimension, const Pose& pose) {
  const Eigen::Matrix3d rotation = pose.rotation.toRotationMatrix();
  const Eigen::Vector3d& t = pose.translation;
  if (dimension == 2) {
    Eigen::MatrixXd ad = Eigen::MatrixXd::Identity(3, 3);
    ad.topLeftCorner<2, 2>() = rotation.topLeftCorner<2, 2>();
    ad(0, 2) = t.y();
    ad(1, 2) = -t.x();
    return ad;
  }
  Eigen::Matrix3d t_hat;
  t_hat << 0.0, -t.z(), t.y(), t.z(), 0.0, -t.x(), -t.y(), t.x(), 0.0;
  Eigen::MatrixXd ad = Eigen::MatrixXd::Zero(6, 6);
  ad.topLeftCorner<3, 3>() = rotation;
  ad.topRightCorner<3, 3>() = t_hat * rotation;
  ad.bottomRightCorner<3, 3>() = rotation;
  return ad;
}

// The same measurement expressed from the other endpoint. With z' = z^-1 the
// residuals relate as e' = J e, J = -Ad(z) (to first order; exact at e = 0),
// so the same Gaussian has information J^-T * info * J^-1.
Edge reverseEdge(int dimension, const Edge& edge) {
  Edge reversed = edge;
  std::swap(reversed.from, reversed.to);
  reversed.measurement = edge.measurement.inverse();
  const Eigen::MatrixXd j_inverse = (-adjoint(dimension, edge.measurement)).inverse();
  const Eigen::MatrixXd info = j_inverse.transpose() * edge.information * j_inverse;
  reversed.information = 0.5 * (info + info.transpose());
  return reversed;
}

LogEntry priorEntry(const PoseGraph& graph, int id, double information) {
  LogEntry entry;
  entry.type = EntryType::kPrior;
  entry.edge.from = id;
  entry.edge.to = id;
  entry.edge.measurement = graph.poses[id];
  const int n = graph.tangentDimension();
  entry.edge.information = information * Eigen::MatrixXd::Identity(n, n);
  entry.edge.kind = EdgeKind::kOdometry;  // a known inlier
  return entry;
}

LogEntry edgeEntry(const Edge& edge) {
  LogEntry entry;
  entry.type = edge.kind == EdgeKind::kLoopClosure ? EntryType::kLoopClosure : EntryType::kOdometry;
  entry.edge = edge;
  return entry;
}

}  // namespace

int IncrementalLog::numPoses() const {
  int max_id = -1;
  for (const LogEntry& entry : entries) max_id = std::max({max_id, entry.edge.from, entry.edge.to});
  return max_id + 1;
}

int IncrementalLog::numLoopClosures() const {
  return static_cast<int>(std::count_if(entries.begin(), entries.end(), [](const LogEntry& e) {
    return e.type == EntryType::kLoopClosure;
  }));
}

int IncrementalLog::numOutliers() const {
  return static_cast<int>(std::count_if(entries.begin(), entries.end(), [](const LogEntry& e) {
    return e.type == EntryType::kLoopClosure && e.edge.is_outlier;
  }));
}

IncrementalLog logFromGraph(const PoseGraph& graph, const std::string& name) {
  IncrementalLog log;
  log.name = name;
  log.dimension = graph.dimension;
  log.file_ids = graph.file_ids;
  const int n = static_cast<int>(graph.poses.size());
  if (n == 0) return log;

  // The first odometry edge of each consecutive pair drives the replay; every
  // other edge (loops, parallel odometry) waits for its newer endpoint.
  std::vector<int> odometry(n - 1, -1);
  std::vector<std::vector<int>> by_newer_pose(n);
  for (int i = 0; i < static_cast<int>(graph.edges.size()); ++i) {
    const Edge& e = graph.edges[i];
    if (e.from < 0 || e.to < 0 || e.from >= n || e.to >= n) {
      throw std::invalid_argument("logFromGraph: edge " + std::to_string(i) +
                                  " references a pose outside 0.." + std::to_string(n - 1));
    }
    const int older = std::min(e.from, e.to);
    if (e.kind == EdgeKind::kOdometry && std::abs(e.from - e.to) == 1 && odometry[older] < 0) {
      odometry[older] = i;
    } else {
      by_newer_pose[std::max(e.from, e.to)].push_back(i);
    }
  }

  log.entries.push_back(priorEntry(graph, 0, kPriorInformation));
  for (int i : by_newer_pose[0]) log.entries.push_back(edgeEntry(graph.edges[i]));
  for (int k = 0; k + 1 < n; ++k) {
    if (odometry[k] < 0) {
      // A gap in the odometry (a second session, a restarted robot): the new
      // chain starts where the graph puts it, held by a weak prior, until its
      // loop closures attach it to the rest.
      log.entries.push_back(priorEntry(graph, k + 1, kChainPriorInformation));
    } else {
      const Edge& e = graph.edges[odometry[k]];
      log.entries.push_back(edgeEntry(e.from == k ? e : reverseEdge(graph.dimension, e)));
    }
    for (int i : by_newer_pose[k + 1]) log.entries.push_back(edgeEntry(graph.edges[i]));
  }
  return log;
}

PoseGraph graphFromLog(const IncrementalLog& log) {
  PoseGraph graph;
  graph.dimension = log.dimension;
  graph.file_ids = log.file_ids;
  graph.poses.assign(log.numPoses(), Pose::identity());
  bool anchored = false;
  for (const LogEntry& entry : log.entries) {
    if (entry.type == EntryType::kPrior) {
      // The first prior on pose 0 and the start of every later odometry
      // chain seed the initial guess; PoseGraph has no prior factors, so
      // the priors themselves are not represented.
      if (entry.edge.to != 0 || !anchored) graph.poses[entry.edge.to] = entry.edge.measurement;
      anchored = anchored || entry.edge.to == 0;
      continue;
    }
    Edge edge = entry.edge;
    edge.kind =
        entry.type == EntryType::kLoopClosure ? EdgeKind::kLoopClosure : EdgeKind::kOdometry;
    graph.edges.push_back(edge);
  }
  initializeFromOdometry(&graph);
  return graph;
}

}  // namespace core
}  // namespace agnc_pgo
