// The rviz panel's model: message -> rows, sorting, filtering, status text,
// selection marker (no Qt, no master).
#include <gtest/gtest.h>

#include "agnc_pgo/rviz/loop_closure_table.h"

namespace agnc_pgo {
namespace panel {
namespace {

agnc_pgo::PoseGraphEdge loop(int index, int from, int to, bool inlier, const std::string& source,
                             double test_distance) {
  agnc_pgo::PoseGraphEdge e;
  e.type = agnc_pgo::PoseGraphEdge::LOOP_CLOSURE;
  e.loop_index = index;
  e.from_id = from;
  e.to_id = to;
  e.inlier = inlier;
  e.source = source;
  e.test_distance = test_distance;
  e.threshold = 2.45;
  e.mu = inlier ? 1.0 : 0.02;
  e.weight = inlier ? 0.9 : 1e-7;
  e.decided_in_update = index + 10;
  return e;
}

agnc_pgo::PoseGraph graph() {
  agnc_pgo::PoseGraph g;
  g.header.frame_id = "map";
  for (int i = 0; i < 6; ++i) {
    agnc_pgo::PoseGraphNode n;
    n.id = i;
    n.stamp = ros::Time(100 + i);
    n.pose.position.x = i;
    n.pose.position.y = 2 * i;
    n.pose.orientation.w = 1;
    g.nodes.push_back(n);
  }
  agnc_pgo::PoseGraphEdge odometry;
  odometry.type = agnc_pgo::PoseGraphEdge::ODOMETRY;
  odometry.loop_index = -1;
  g.edges.push_back(odometry);
  g.edges.push_back(loop(2, 1, 5, true, "true", 0.3));
  g.edges.push_back(loop(0, 0, 4, false, "outlier", 40.0));
  g.edges.push_back(loop(1, 2, 3, false, "true", 7.5));
  g.edges.back().dormant = true;
  g.edges.back().mode = agnc_pgo::PoseGraphEdge::FORCE_OUTLIER;
  g.edges.push_back(loop(3, 3, 5, true, "true", 0.1));
  g.edges.back().graduating = true;
  g.edges.back().uncorroborated = true;
  return g;
}

std::vector<int> indices(const LoopClosureTable& t) {
  std::vector<int> out;
  for (int i = 0; i < t.size(); ++i) out.push_back(t.row(i).index);
  return out;
}

TEST(LoopClosureRows, OneRowPerLoopClosureInIndexOrder) {
  const auto rows = rowsFromGraph(graph());
  ASSERT_EQ(rows.size(), 4u);
  EXPECT_EQ(rows[0].index, 0);
  EXPECT_EQ(rows[0].from, 0);
  EXPECT_EQ(rows[0].to, 4);
  EXPECT_DOUBLE_EQ(rows[0].from_stamp, 100.0);
  EXPECT_DOUBLE_EQ(rows[0].to_stamp, 104.0);
  EXPECT_EQ(rows[0].state, "outlier");
  EXPECT_EQ(rows[0].override_mode, "auto");
  EXPECT_DOUBLE_EQ(rows[0].test_distance, 40.0);
  EXPECT_DOUBLE_EQ(rows[0].threshold, 2.45);
  EXPECT_EQ(rows[0].decided_in_update, 10);
  EXPECT_EQ(rows[1].state, "outlier (dormant)");
  EXPECT_EQ(rows[1].override_mode, "force outlier");
  EXPECT_EQ(rows[2].state, "inlier");
  EXPECT_EQ(rows[3].state, "graduating");
  EXPECT_TRUE(rows[3].uncorroborated);
  EXPECT_EQ(cellText(rows[3], Column::kUncorroborated), "uncorroborated");
  EXPECT_EQ(cellText(rows[0], Column::kDistance), "40");
  EXPECT_EQ(cellText(rows[0], Column::kFromStamp), "100.000");
}

TEST(LoopClosureTable, SortsNumbersAsNumbersBothWays) {
  LoopClosureTable t;
  t.setRows(rowsFromGraph(graph()));
  EXPECT_EQ(indices(t), (std::vector<int>{0, 1, 2, 3}));
  t.sortBy(Column::kDistance, false);
  EXPECT_EQ(indices(t), (std::vector<int>{0, 1, 2, 3}));  // 40, 7.5, 0.3, 0.1
  t.sortBy(Column::kDistance, true);
  EXPECT_EQ(indices(t), (std::vector<int>{3, 2, 1, 0}));
  t.sortBy(Column::kFrom, true);
  EXPECT_EQ(indices(t), (std::vector<int>{0, 2, 1, 3}));
}

TEST(LoopClosureTable, FilterKeepsRowsWithEveryWordAndSurvivesNewRows) {
  LoopClosureTable t;
  t.setRows(rowsFromGraph(graph()));
  t.setFilter("OUTLIER true");  // rejected true loop closures (case-insensitive)
  EXPECT_EQ(indices(t), (std::vector<int>{1}));
  EXPECT_EQ(t.total(), 4);
  t.setFilter("outlier");
  EXPECT_EQ(indices(t), (std::vector<int>{0, 1}));
  t.sortBy(Column::kIndex, false);
  t.setRows(rowsFromGraph(graph()));  // a new ~pose_graph: filter and order stay
  EXPECT_EQ(indices(t), (std::vector<int>{1, 0}));
  EXPECT_EQ(t.findLoopIndex(0), 1);
  EXPECT_EQ(t.findLoopIndex(2), -1);  // filtered out
  t.setFilter("");
  EXPECT_EQ(t.size(), 4);
}

TEST(StatusLines, CountsLatencyAndWarning) {
  agnc_pgo::GraphStatus s;
  s.nodes = 3500;
  s.loop_closures = 2332;
  s.inliers = 2099;
  s.outliers = 233;
  s.latency_ms_p50 = 0.84;
  s.latency_ms_p95 = 3.6;
  s.latency_ms_max = 56.5;
  s.paused = true;
  s.last_warning = "rejected loop closure: bad";
  const auto lines = statusLines(s);
  ASSERT_EQ(lines.size(), 4u);
  EXPECT_EQ(lines[0], "nodes 3500 | loop closures 2332: 2099 inliers, 233 outliers, 0 graduating | PAUSED");
  EXPECT_NE(lines[1].find("0.8 / 3.6 / 56.5 ms"), std::string::npos) << lines[1];
  EXPECT_EQ(lines[3], "last warning: rejected loop closure: bad");
}

TEST(StatusLines, NoiseScaleShownOnlyWhenCovariancesWereWidened) {
  agnc_pgo::GraphStatus s;
  s.noise_scale_translation = 1.0;
  s.noise_scale_rotation = 1.0;
  EXPECT_EQ(statusLines(s).size(), 3u);
  s.noise_scale_translation = 1.9;
  s.noise_scale_rotation = 154.2;
  const auto lines = statusLines(s);
  ASSERT_EQ(lines.size(), 4u);
  EXPECT_EQ(lines[3], "covariances widened (noise scale): translation x1.9, rotation x154");
}

TEST(SelectionMarker, LineBetweenTheEndpointsOrDelete) {
  const agnc_pgo::PoseGraph g = graph();
  const auto m = selectionMarker(g, 1);  // nodes 2 -> 3
  EXPECT_EQ(m.action, visualization_msgs::Marker::ADD);
  EXPECT_EQ(m.header.frame_id, "map");
  ASSERT_EQ(m.points.size(), 2u);
  EXPECT_DOUBLE_EQ(m.points[0].x, 2.0);
  EXPECT_DOUBLE_EQ(m.points[1].y, 6.0);
  EXPECT_EQ(selectionMarker(g, 17).action, visualization_msgs::Marker::DELETE);
  EXPECT_EQ(selectionMarker(g, -1).action, visualization_msgs::Marker::DELETE);
}

}  // namespace
}  // namespace panel
}  // namespace agnc_pgo
