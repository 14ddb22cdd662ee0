// The interactive-marker pieces of loop_closure_menu (no master needed).
#include <gtest/gtest.h>

#include "agnc_pgo/SetLoopClosureStatus.h"
#include "agnc_pgo/ros/loop_closure_menu.h"

namespace agnc_pgo {
namespace ros_backend {
namespace {

TEST(LoopClosureMenu, NamesRoundTripAndRejectOthers) {
  EXPECT_EQ(markerName(12), "loop_closure_12");
  EXPECT_EQ(loopIndexOf(markerName(0)), 0);
  EXPECT_EQ(loopIndexOf(markerName(2331)), 2331);
  EXPECT_EQ(loopIndexOf("loop_closure_"), -1);
  EXPECT_EQ(loopIndexOf("loop_closure_1x"), -1);
  EXPECT_EQ(loopIndexOf("node_3"), -1);
  EXPECT_EQ(loopIndexOf("loop_closure_99999999999"), -1);
}

TEST(LoopClosureMenu, EntriesMapToModes) {
  using Request = agnc_pgo::SetLoopClosureStatus::Request;
  EXPECT_EQ(modeOfMenuEntry(kMenuForceInlier), Request::FORCE_INLIER);
  EXPECT_EQ(modeOfMenuEntry(kMenuForceOutlier), Request::FORCE_OUTLIER);
  EXPECT_EQ(modeOfMenuEntry(kMenuAutomatic), Request::AUTO);
  EXPECT_EQ(modeOfMenuEntry(0), -1);
  EXPECT_EQ(modeOfMenuEntry(4), -1);
}

TEST(LoopClosureMenu, MarkerAtTheMidpointColouredByState) {
  agnc_pgo::PoseGraph g;
  g.header.frame_id = "map";
  g.nodes.resize(3);
  g.nodes[0].pose.position.x = 0;
  g.nodes[2].pose.position.x = 4;
  g.nodes[2].pose.position.y = 2;
  agnc_pgo::PoseGraphEdge e;
  e.type = e.LOOP_CLOSURE;
  e.loop_index = 7;
  e.from_id = 0;
  e.to_id = 2;
  e.inlier = false;
  const auto m = loopClosureMarker(g, e, 0.5);
  EXPECT_EQ(m.name, "loop_closure_7");
  EXPECT_EQ(m.header.frame_id, "map");
  EXPECT_DOUBLE_EQ(m.pose.position.x, 2.0);
  EXPECT_DOUBLE_EQ(m.pose.position.y, 1.0);
  ASSERT_EQ(m.controls.size(), 1u);
  EXPECT_EQ(m.controls[0].interaction_mode, visualization_msgs::InteractiveMarkerControl::MENU);
  ASSERT_EQ(m.controls[0].markers.size(), 1u);
  EXPECT_FLOAT_EQ(m.controls[0].markers[0].color.r, 1.0f);  // rejected: red
  EXPECT_NE(m.description.find("outlier"), std::string::npos);
  e.inlier = true;
  EXPECT_FLOAT_EQ(loopClosureMarker(g, e, 0.5).controls[0].markers[0].color.g, 0.8f);
}

}  // namespace
}  // namespace ros_backend
}  // namespace agnc_pgo
