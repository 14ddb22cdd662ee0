// The dataset player's data side (loadPlayerDataset, ROS-free): it must
// stream exactly the loop closures agnc_pgo_replay injects for the same
// options, in every outlier mode, and refuse options it cannot honour.
#include "agnc_pgo/ros/dataset_player.h"

#include <algorithm>
#include <map>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "agnc_pgo/core/g2o_io.h"
#include "agnc_pgo/eval/outlier_injection.h"

namespace agnc_pgo {
namespace ros_backend {
namespace {

// The rostests' generated grid world (CMake: agnc_pgo_test_world), 400 poses.
const std::string kWorld = std::string(AGNC_PGO_TEST_WORLD_DIR) + "/grid2d_400_seed1.g2o";
const std::string kWorldName = "grid2d_400_seed1";

// (from, to, measurement as text) of a loop closure: identical iff the edges
// are the same pair with the same measurement bit for bit.
using LoopKey = std::tuple<int, int, double, double, double, double>;

LoopKey keyOf(const core::Edge& e) {
  return LoopKey(e.from, e.to, e.measurement.translation.x(), e.measurement.translation.y(),
                 e.measurement.rotation.z(), e.measurement.rotation.w());
}

std::vector<LoopKey> outliersOf(const PlayerDataset& data) {
  std::vector<LoopKey> keys;
  for (const PlayerEntry& entry : data.entries)
    if (entry.type == PlayerEntry::Type::kLoopClosure && entry.loop.is_outlier) keys.push_back(keyOf(entry.loop));
  std::sort(keys.begin(), keys.end());
  return keys;
}

std::vector<LoopKey> outliersOf(const core::PoseGraph& graph) {
  std::vector<LoopKey> keys;
  for (const core::Edge& e : graph.edges)
    if (e.is_outlier) keys.push_back(keyOf(e));
  std::sort(keys.begin(), keys.end());
  return keys;
}

core::OutlierOptions optionsFor(core::OutlierMode mode, double percent, unsigned long seed, int group_size) {
  core::OutlierOptions options;
  options.mode = mode;
  options.percent = percent;
  options.seed = seed;
  options.group_size = group_size;
  return options;
}

TEST(DatasetPlayer, StreamsWhatTheReplayInjectsInEveryMode) {
  const core::PoseGraph graph = core::readG2o(kWorld);
  for (core::OutlierMode mode : {core::OutlierMode::kRandom, core::OutlierMode::kLocal,
                                 core::OutlierMode::kRandomGrouped, core::OutlierMode::kLocalGrouped}) {
    SCOPED_TRACE(core::toString(mode));
    const PlayerDataset data = loadPlayerDataset(kWorld, 20.0, 3, mode, 5);
    const core::PoseGraph expected =
        core::injectOutliersAgainstOptimum(graph, kWorldName, optionsFor(mode, 20.0, 3, 5));
    const std::vector<LoopKey> streamed = outliersOf(data);
    EXPECT_EQ(streamed, outliersOf(expected));
    EXPECT_EQ(data.outliers, static_cast<int>(streamed.size()));
    EXPECT_GT(data.outliers, 0);
    EXPECT_EQ(data.poses, static_cast<int>(graph.poses.size()));
  }
}

TEST(DatasetPlayer, LocalGroupsArriveAsRunsOfConsecutivePairs) {
  const PlayerDataset data = loadPlayerDataset(kWorld, 20.0, 1, core::OutlierMode::kLocalGrouped, 4);
  // Members of a group share one measurement: collect them by it.
  std::map<std::vector<double>, std::vector<core::Edge>> groups;
  for (const PlayerEntry& entry : data.entries) {
    if (entry.type != PlayerEntry::Type::kLoopClosure || !entry.loop.is_outlier) continue;
    const core::Pose& z = entry.loop.measurement;
    groups[{z.translation.x(), z.translation.y(), z.rotation.z(), z.rotation.w()}].push_back(entry.loop);
  }
  ASSERT_GE(groups.size(), 2u);
  int members = 0;
  for (auto& [z, edges] : groups) {
    std::sort(edges.begin(), edges.end(), [](const core::Edge& a, const core::Edge& b) { return a.from < b.from; });
    EXPECT_LE(edges.size(), 4u);
    for (size_t k = 0; k < edges.size(); ++k) {
      EXPECT_GE(edges[k].from - edges[k].to, 20);
      EXPECT_LE(edges[k].from - edges[k].to, 50);
      if (k > 0) {
        EXPECT_EQ(edges[k].from, edges[k - 1].from + 1);
        EXPECT_EQ(edges[k].to, edges[k - 1].to + 1);
      }
    }
    members += static_cast<int>(edges.size());
  }
  EXPECT_EQ(members, data.outliers);
}

TEST(DatasetPlayer, WithoutOutliersTheModeChangesNothing) {
  const PlayerDataset random = loadPlayerDataset(kWorld, 0.0, 1, core::OutlierMode::kRandom, 10);
  const PlayerDataset grouped = loadPlayerDataset(kWorld, 0.0, 1, core::OutlierMode::kLocalGrouped, 3);
  EXPECT_EQ(random.outliers, 0);
  EXPECT_EQ(grouped.outliers, 0);
  EXPECT_EQ(random.loop_closures, grouped.loop_closures);
  EXPECT_EQ(random.entries.size(), grouped.entries.size());
}

TEST(DatasetPlayer, RefusesOptionsItCannotHonour) {
  EXPECT_THROW(loadPlayerDataset(kWorld, 10.0, 1, core::OutlierMode::kRandomGrouped, 0), std::invalid_argument);
  EXPECT_THROW(loadPlayerDataset(kWorld, 100.0, 1), std::invalid_argument);
  EXPECT_THROW(loadPlayerDataset(kWorld, -1.0, 1), std::invalid_argument);
  EXPECT_THROW(loadPlayerDataset(kWorld + ".missing", 0.0, 1), std::runtime_error);
}

}  // namespace
}  // namespace ros_backend
}  // namespace agnc_pgo
