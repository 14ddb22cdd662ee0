// The panel's model against the running back-end (panel.test): rows made
// from ~pose_graph, a true inlier chosen through the table's filter, forced
// to be an outlier through BackendCommands (what the panel's button calls),
// and ~pose_graph, read back through the model, shows it.
#include <gtest/gtest.h>

#include <ros/ros.h>
#include <std_msgs/Bool.h>

#include "agnc_pgo/SetLoopClosureStatus.h"
#include "agnc_pgo/rviz/backend_commands.h"
#include "agnc_pgo/rviz/loop_closure_table.h"

namespace agnc_pgo {
namespace panel {
namespace {

const std::string kBackend = "/agnc_pgo_backend";

// Spins until `done()` or the timeout; true if done.
template <typename Predicate>
bool spinUntil(Predicate done, double timeout) {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout);
  while (ros::ok() && ros::WallTime::now() < deadline) {
    ros::spinOnce();
    if (done()) return true;
    ros::WallDuration(0.05).sleep();
  }
  return false;
}

TEST(PanelAgainstBackend, ForceOutlierFromTheModelShowsInThePoseGraph) {
  ros::NodeHandle nh;
  agnc_pgo::PoseGraph::ConstPtr graph;
  agnc_pgo::GraphStatus::ConstPtr status;
  bool player_done = false;
  auto g = nh.subscribe<agnc_pgo::PoseGraph>(kBackend + "/pose_graph", 1, [&](const agnc_pgo::PoseGraph::ConstPtr& m) { graph = m; });
  auto s = nh.subscribe<agnc_pgo::GraphStatus>(kBackend + "/status", 1, [&](const agnc_pgo::GraphStatus::ConstPtr& m) { status = m; });
  auto d = nh.subscribe<std_msgs::Bool>("/dataset_player/done", 1, [&](const std_msgs::Bool::ConstPtr& m) { player_done = m->data; });
  ASSERT_TRUE(spinUntil([&] {
    return player_done && status && graph && status->graduating == 0 &&
           rowsFromGraph(*graph).size() == status->loop_closures && status->loop_closures > 0;
  }, 60.0)) << "the back-end did not settle";

  LoopClosureTable table;
  table.setRows(rowsFromGraph(*graph));
  table.setFilter("inlier true");
  ASSERT_GT(table.size(), 0);
  const LoopClosureRow chosen = table.row(0);
  EXPECT_EQ(chosen.state, "inlier");
  EXPECT_EQ(chosen.override_mode, "auto");

  const CommandOutcome outcome =
      BackendCommands(kBackend).setOverride(chosen.index, agnc_pgo::SetLoopClosureStatus::Request::FORCE_OUTLIER);
  ASSERT_TRUE(outcome.success) << outcome.message;
  EXPECT_NE(outcome.message.find("outlier"), std::string::npos) << outcome.message;

  ASSERT_TRUE(spinUntil([&] {
    table.setRows(rowsFromGraph(*graph));
    table.setFilter("");
    const int row = table.findLoopIndex(chosen.index);
    return row >= 0 && table.row(row).override_mode == "force outlier";
  }, 30.0));
  const LoopClosureRow after = table.row(table.findLoopIndex(chosen.index));
  EXPECT_EQ(after.state.substr(0, 7), "outlier");
  EXPECT_EQ(after.from, chosen.from);
  EXPECT_EQ(after.to, chosen.to);

  // Failure is reported, not thrown: an index the graph does not have.
  const CommandOutcome bad = BackendCommands(kBackend).setOverride(100000, 0);
  EXPECT_FALSE(bad.success);
  EXPECT_NE(bad.message.find("unknown loop closure"), std::string::npos) << bad.message;
}

}  // namespace
}  // namespace panel
}  // namespace agnc_pgo

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_panel_backend");
  return RUN_ALL_TESTS();
}
