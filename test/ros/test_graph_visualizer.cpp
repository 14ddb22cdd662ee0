// The rviz markers: every edge in the line list of its state (odometry,
// inlier, outlier, graduating shaded by weight), the counts in the status
// text, and empty line lists deleted rather than left stale.
#include <string>

#include <gtest/gtest.h>

#include "agnc_pgo/ros/graph_visualizer.h"

using namespace agnc_pgo;
using namespace agnc_pgo::ros_backend;

namespace {

GraphSnapshot snapshotWithNodes(int count) {
  GraphSnapshot snapshot;
  for (int i = 0; i < count; ++i) {
    SnapshotNode node;
    node.pose = core::Pose::fromSE2(2.0 * i, 0.0, 0.0);
    snapshot.nodes.push_back(node);
  }
  return snapshot;
}

SnapshotEdge edge(SnapshotEdgeType type, int from, int to) {
  SnapshotEdge e;
  e.type = type;
  e.from = from;
  e.to = to;
  return e;
}

const visualization_msgs::Marker& find(const visualization_msgs::MarkerArray& array, const std::string& ns) {
  for (const visualization_msgs::Marker& m : array.markers)
    if (m.ns == ns) return m;
  throw std::runtime_error("no marker in namespace " + ns);
}

}  // namespace

TEST(GraphVisualizer, EdgesGoToTheListOfTheirStateAndTheStatusCountsThem) {
  GraphSnapshot snapshot = snapshotWithNodes(4);
  snapshot.edges.push_back(edge(SnapshotEdgeType::kPrior, 0, 0));
  for (int i = 0; i < 3; ++i) snapshot.edges.push_back(edge(SnapshotEdgeType::kOdometry, i, i + 1));
  SnapshotEdge inlier = edge(SnapshotEdgeType::kLoopClosure, 0, 2);
  SnapshotEdge outlier = edge(SnapshotEdgeType::kLoopClosure, 0, 3);
  outlier.inlier = false;
  SnapshotEdge graduating = edge(SnapshotEdgeType::kLoopClosure, 1, 3);
  graduating.graduating = true;
  graduating.weight = 0.5;
  snapshot.edges.push_back(inlier);
  snapshot.edges.push_back(outlier);
  snapshot.edges.push_back(graduating);

  const visualization_msgs::MarkerArray array = makeMarkers(snapshot, VisualizerStyle());
  EXPECT_EQ(find(array, kNodesNamespace).points.size(), 4u);
  EXPECT_EQ(find(array, kOdometryNamespace).points.size(), 6u);  // the prior draws no line
  EXPECT_EQ(find(array, kInlierNamespace).points.size(), 2u);
  EXPECT_EQ(find(array, kOutlierNamespace).points.size(), 2u);
  const visualization_msgs::Marker& shaded = find(array, kGraduatingNamespace);
  ASSERT_EQ(shaded.points.size(), 2u);
  ASSERT_EQ(shaded.colors.size(), 2u);
  EXPECT_FLOAT_EQ(shaded.colors[0].g, 0.6f);  // weight 0.5: halfway from orange-red to yellow-green
  EXPECT_DOUBLE_EQ(shaded.points[1].x, 6.0);
  const visualization_msgs::Marker& text = find(array, kStatusNamespace);
  EXPECT_EQ(text.text, "4 nodes | 3 loop closures: 1 inliers (green), 1 outliers (red), 1 graduating");
  for (const visualization_msgs::Marker& m : array.markers)
    EXPECT_EQ(m.action, visualization_msgs::Marker::ADD) << m.ns;
}

TEST(GraphVisualizer, StatusCarriesTheNoiseScalePerBlock) {
  ros::Time::init();  // the status is stamped
  StatusInfo info;
  EXPECT_EQ(makeStatus(info).noise_scale_translation, 1.0);  // as stated until the engine widens
  info.noise_scale_translation = 1.9;
  info.noise_scale_rotation = 154.0;
  const agnc_pgo::GraphStatus msg = makeStatus(info);
  EXPECT_EQ(msg.noise_scale_translation, 1.9);
  EXPECT_EQ(msg.noise_scale_rotation, 154.0);
}

TEST(GraphVisualizer, EmptyLineListsAreDeletedNotLeftStale) {
  const GraphSnapshot snapshot = snapshotWithNodes(2);  // no edges requested
  const visualization_msgs::MarkerArray array = makeMarkers(snapshot, VisualizerStyle());
  EXPECT_EQ(find(array, kNodesNamespace).action, visualization_msgs::Marker::ADD);
  EXPECT_EQ(find(array, kStatusNamespace).action, visualization_msgs::Marker::ADD);
  EXPECT_EQ(find(array, kStatusNamespace).text,
            "2 nodes | 0 loop closures: 0 inliers (green), 0 outliers (red), 0 graduating");
  for (const char* ns : {kOdometryNamespace, kInlierNamespace, kOutlierNamespace, kGraduatingNamespace})
    EXPECT_EQ(find(array, ns).action, visualization_msgs::Marker::DELETE) << ns;
}
