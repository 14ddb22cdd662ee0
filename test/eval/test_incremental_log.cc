#include "agnc_pgo/eval/incremental_log.h"

#include <algorithm>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "shared_datasets.h"

#include "agnc_pgo/core/g2o_io.h"

namespace agnc_pgo {
namespace core {
namespace {

std::string dataset(const std::string& file) {
  return std::string(AGNC_PGO_SHARED_DIR) + "/datasets/" + file;
}

// Checks the replay order: each odometry k -> k+1 introduces the next pose
// and every other edge arrives right after its newer endpoint appeared.
void expectPoseOrder(const IncrementalLog& log) {
  ASSERT_FALSE(log.entries.empty());
  ASSERT_EQ(log.entries[0].type, EntryType::kPrior);
  int newest = 0;
  for (size_t i = 1; i < log.entries.size(); ++i) {
    const LogEntry& entry = log.entries[i];
    ASSERT_NE(entry.type, EntryType::kPrior) << i;
    const Edge& e = entry.edge;
    if (e.to == newest + 1) {
      ASSERT_EQ(entry.type, EntryType::kOdometry) << i;
      ASSERT_EQ(e.from, newest) << i;
      newest = e.to;
    } else {
      ASSERT_EQ(std::max(e.from, e.to), newest) << "entry " << i << " arrives out of order";
    }
  }
  EXPECT_EQ(newest + 1, log.numPoses());
}

// The graph's edges in the order logFromGraph should emit them: grouped by
// newer endpoint, odometry first, file order otherwise.
std::vector<Edge> expectedOrder(const PoseGraph& g) {
  std::vector<Edge> edges = g.edges;
  std::stable_sort(edges.begin(), edges.end(), [](const Edge& a, const Edge& b) {
    const int na = std::max(a.from, a.to), nb = std::max(b.from, b.to);
    if (na != nb) return na < nb;
    return a.kind == EdgeKind::kOdometry && b.kind == EdgeKind::kLoopClosure;
  });
  return edges;
}

void expectSameEdges(const std::vector<Edge>& expected, const std::vector<Edge>& actual) {
  ASSERT_EQ(expected.size(), actual.size());
  for (size_t i = 0; i < expected.size(); ++i) {
    const Edge& a = expected[i];
    const Edge& b = actual[i];
    ASSERT_EQ(a.from, b.from) << i;
    ASSERT_EQ(a.to, b.to) << i;
    ASSERT_EQ(a.kind, b.kind) << i;
    ASSERT_EQ(a.is_outlier, b.is_outlier) << i;
    ASSERT_TRUE(a.measurement.translation == b.measurement.translation) << i;
    ASSERT_TRUE(a.measurement.rotation.coeffs() == b.measurement.rotation.coeffs()) << i;
    ASSERT_TRUE(a.information == b.information) << i;
  }
}

TEST(IncrementalLog, CsailReplaysInPoseOrder) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  const PoseGraph g = readG2o(dataset("csail.g2o"));
  const IncrementalLog log = logFromGraph(g, "csail");
  EXPECT_EQ(log.name, "csail");
  EXPECT_EQ(log.dimension, 2);
  ASSERT_EQ(log.entries.size(), 1u + 1044u + 128u);
  EXPECT_EQ(log.numPoses(), 1045);
  EXPECT_EQ(log.numLoopClosures(), 128);
  EXPECT_EQ(log.numOutliers(), 0);
  int odometry = 0;
  for (const LogEntry& e : log.entries) odometry += e.type == EntryType::kOdometry;
  EXPECT_EQ(odometry, 1044);

  const LogEntry& prior = log.entries[0];
  EXPECT_EQ(prior.edge.to, 0);
  EXPECT_TRUE(prior.edge.measurement.translation == g.poses[0].translation);
  EXPECT_TRUE(prior.edge.information == 1e8 * Eigen::MatrixXd::Identity(3, 3));
  expectPoseOrder(log);

  std::vector<Edge> logged;
  for (size_t i = 1; i < log.entries.size(); ++i) logged.push_back(log.entries[i].edge);
  expectSameEdges(expectedOrder(g), logged);
}

TEST(IncrementalLog, RingWithBackwardsLoops) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  const PoseGraph g = readG2o(dataset("ring.g2o"));
  const IncrementalLog log = logFromGraph(g, "ring");
  ASSERT_EQ(log.entries.size(), 1u + 433u + 26u);
  EXPECT_EQ(log.numLoopClosures(), 26);
  expectPoseOrder(log);
  for (const LogEntry& e : log.entries) {
    // Loops keep their i > j direction; they arrive when i appears.
    if (e.type == EntryType::kLoopClosure) {
      EXPECT_GT(e.edge.from, e.edge.to);
    }
  }
}

TEST(IncrementalLog, Sphere2500In3D) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  const PoseGraph g = readG2o(dataset("sphere2500.g2o"));
  const IncrementalLog log = logFromGraph(g, "sphere2500");
  EXPECT_EQ(log.dimension, 3);
  ASSERT_EQ(log.entries.size(), 1u + 2499u + 2450u);
  EXPECT_TRUE(log.entries[0].edge.information == 1e8 * Eigen::MatrixXd::Identity(6, 6));
  expectPoseOrder(log);
}

TEST(IncrementalLog, GraphFromLogRestoresEdges) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  for (const char* file : {"csail.g2o", "ring.g2o", "smallGrid3D.g2o", "manhattanOlson3500.g2o"}) {
    SCOPED_TRACE(file);
    const PoseGraph g = readG2o(dataset(file));
    const PoseGraph back = graphFromLog(logFromGraph(g, file));
    EXPECT_EQ(back.dimension, g.dimension);
    ASSERT_EQ(back.poses.size(), g.poses.size());
    EXPECT_EQ(back.numLoopClosures(), g.numLoopClosures());
    expectSameEdges(expectedOrder(g), back.edges);
    // Pose 0 is the prior's value; the rest is composed odometry.
    EXPECT_TRUE(back.poses[0].translation == g.poses[0].translation);
    Pose composed = g.poses[0];
    for (const Edge& e : back.edges) {
      if (e.kind == EdgeKind::kOdometry && e.to == e.from + 1) {
        composed = composed * e.measurement;
        ASSERT_LT((back.poses[e.to].translation - composed.translation).norm(), 1e-9) << e.to;
      }
    }
  }
}

// Mahalanobis distance of an edge from `from` to `to` at the given poses.
double distance(int dimension, const Pose& x_from, const Pose& x_to, const Pose& z,
                const Eigen::MatrixXd& info) {
  const Eigen::VectorXd e = relativePoseError(dimension, x_from, x_to, z);
  return e.dot(info * e);
}

// A 2-pose graph whose only odometry is written 1 -> 0.
PoseGraph backwardsOdometry(int dimension, const Pose& x0, const Pose& x1,
                            const Eigen::MatrixXd& info) {
  PoseGraph g;
  g.dimension = dimension;
  g.poses = {x0, x1};
  Edge edge;
  edge.from = 1;
  edge.to = 0;
  edge.measurement = x1.inverse() * x0;
  edge.information = info;
  edge.kind = EdgeKind::kOdometry;
  g.edges.push_back(edge);
  return g;
}

void expectReversedEdgeIsSameGaussian(int dimension, const Pose& x0, const Pose& x1,
                                      const Eigen::MatrixXd& info,
                                      const std::vector<Pose>& deltas) {
  const PoseGraph g = backwardsOdometry(dimension, x0, x1, info);
  const IncrementalLog log = logFromGraph(g, "reversed");
  ASSERT_EQ(log.entries.size(), 2u);
  const Edge& fwd = log.entries[1].edge;
  ASSERT_EQ(fwd.from, 0);
  ASSERT_EQ(fwd.to, 1);
  const Edge& orig = g.edges[0];
  // The measurement is inverted and the information stays symmetric.
  const Pose round_trip = orig.measurement * fwd.measurement;
  EXPECT_LT(round_trip.translation.norm(), 1e-12);
  EXPECT_LT(round_trip.rotation.angularDistance(Eigen::Quaterniond::Identity()), 1e-12);
  EXPECT_TRUE(fwd.information == fwd.information.transpose());
  EXPECT_LT(distance(dimension, x0, x1, fwd.measurement, fwd.information), 1e-20);
  for (const Pose& delta : deltas) {
    // Perturb pose 1 slightly: both edges must see the same error distance.
    const Pose x1_moved = x1 * delta;
    const double d_orig = distance(dimension, x1_moved, x0, orig.measurement, orig.information);
    const double d_fwd = distance(dimension, x0, x1_moved, fwd.measurement, fwd.information);
    const double d_naive = distance(dimension, x0, x1_moved, fwd.measurement, orig.information);
    ASSERT_GT(d_orig, 0.0);
    EXPECT_NEAR(d_fwd / d_orig, 1.0, 1e-3) << d_orig << " vs " << d_fwd;
    // Without the adjoint the information would be wrong by far more.
    EXPECT_GT(std::abs(d_naive / d_orig - 1.0), 0.05);
  }
}

TEST(IncrementalLog, ReversedOdometryKeepsTheGaussian2D) {
  Eigen::MatrixXd info(3, 3);
  info << 50, 10, 5, 10, 80, -4, 5, -4, 300;
  expectReversedEdgeIsSameGaussian(
      2, Pose::fromSE2(1, 2, 0.3), Pose::fromSE2(4, 1, 2.2), info,
      {Pose::fromSE2(1e-4, -2e-4, 3e-4), Pose::fromSE2(-3e-4, 1e-4, 0), Pose::fromSE2(0, 0, 2e-4)});
}

TEST(IncrementalLog, ReversedOdometryKeepsTheGaussian3D) {
  // Anisotropic with translation-rotation coupling, so a wrong transform shows.
  Eigen::VectorXd diagonal(6);
  diagonal << 10, 25, 60, 900, 400, 2500;
  Eigen::MatrixXd info = diagonal.asDiagonal();
  info(0, 4) = info(4, 0) = 20;
  info(1, 3) = info(3, 1) = -15;
  info(2, 5) = info(5, 2) = 30;
  expectReversedEdgeIsSameGaussian(
      3, Pose::fromXYZRPY(1, 2, 3, 0.1, -0.2, 0.3), Pose::fromXYZRPY(-2, 4, 1, 1.0, 0.4, -2.0),
      info,
      {Pose::fromXYZRPY(1e-4, -2e-4, 1e-4, 2e-4, -1e-4, 3e-4),
       Pose::fromXYZRPY(0, 0, 0, 1e-4, 2e-4, -1e-4), Pose::fromXYZRPY(2e-4, 1e-4, -3e-4, 0, 0, 0)});
}

TEST(IncrementalLog, AGapInTheOdometryStartsANewChainWithAWeakPrior) {
  PoseGraph g;
  g.poses = {Pose::fromSE2(0, 0, 0), Pose::fromSE2(1, 0, 0), Pose::fromSE2(5, 5, 1)};
  Edge odometry;
  odometry.from = 0;
  odometry.to = 1;
  odometry.measurement = Pose::fromSE2(1, 0, 0);
  odometry.information = Eigen::MatrixXd::Identity(3, 3);
  odometry.kind = EdgeKind::kOdometry;
  Edge loop = odometry;
  loop.to = 2;
  loop.kind = EdgeKind::kLoopClosure;
  g.edges = {odometry, loop};
  const IncrementalLog log = logFromGraph(g, "two chains");
  ASSERT_EQ(log.entries.size(), 4u);
  EXPECT_EQ(log.entries[0].type, EntryType::kPrior);
  EXPECT_EQ(log.entries[1].type, EntryType::kOdometry);
  // Pose 2 has no odometry from pose 1: a prior at its value, a gauge only.
  EXPECT_EQ(log.entries[2].type, EntryType::kPrior);
  EXPECT_EQ(log.entries[2].edge.to, 2);
  EXPECT_EQ(log.entries[2].edge.measurement.translation, g.poses[2].translation);
  EXPECT_DOUBLE_EQ(log.entries[2].edge.information(0, 0), 1e-6);
  EXPECT_EQ(log.entries[3].type, EntryType::kLoopClosure);
  EXPECT_EQ(log.numPoses(), 3);
  // And back: the chain start keeps its value.
  const PoseGraph back = graphFromLog(log);
  EXPECT_EQ(back.poses[2].translation, g.poses[2].translation);
}

TEST(IncrementalLog, KeepsTheFileIdsOfAGraphWhoseIdsSkipValues) {
  // ETHCampus-like: ids 0, 1 and 9, pose 9 attached by a loop closure only.
  std::istringstream in(
      "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 9 0 1 0\n"
      "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\nEDGE_SE2 0 9 0 1 0 1 0 0 1 0 1\n");
  const PoseGraph g = readG2o(in, "gapped.g2o");
  ASSERT_EQ(g.file_ids, (std::vector<int>{0, 1, 9}));
  const IncrementalLog log = logFromGraph(g, "gapped");
  EXPECT_EQ(log.file_ids, g.file_ids);
  EXPECT_EQ(log.numPoses(), 3);
  // Poses 1 and 2 (ids 1 and 9) are neighbours in order, but no odometry
  // joins them: pose 2 starts a chain that its loop closure attaches.
  ASSERT_EQ(log.entries.size(), 4u);
  EXPECT_EQ(log.entries[2].type, EntryType::kPrior);
  EXPECT_EQ(log.entries[3].type, EntryType::kLoopClosure);
  EXPECT_EQ(graphFromLog(log).file_ids, g.file_ids);
}

}  // namespace
}  // namespace core
}  // namespace agnc_pgo
