#include "agnc_pgo/ros/dataset_player.h"

#include <filesystem>
#include <stdexcept>

#include "agnc_pgo/core/g2o_io.h"
#include "agnc_pgo/eval/incremental_log.h"
#include "agnc_pgo/eval/irl_io.h"
#include "agnc_pgo/eval/metrics.h"
#include "agnc_pgo/eval/outlier_injection.h"

namespace agnc_pgo {
namespace ros_backend {

PlayerDataset loadPlayerDataset(const std::string& path, double outlier_percent, unsigned long seed,
                                core::OutlierMode outlier_mode, int group_size) {
  namespace fs = std::filesystem;
  if (!fs::exists(path)) throw std::runtime_error("dataset " + path + " does not exist");
  if (outlier_percent < 0 || outlier_percent >= 100) throw std::invalid_argument("outliers must be in [0, 100)");
  if (group_size < 1) throw std::invalid_argument("group_size must be at least 1, got " + std::to_string(group_size));
  const std::string stem = fs::path(path).stem().string();
  core::IncrementalLog log;
  if (fs::path(path).extension() == ".irl") {
    if (outlier_percent > 0 || outlier_mode != core::OutlierMode::kRandom)
      throw std::invalid_argument("outlier injection does not apply to .irl logs (their outliers are labelled)");
    log = core::readIrl(path);
  } else {
    core::PoseGraph graph = core::readG2o(path);
    if (outlier_percent > 0) {
      core::OutlierOptions options;
      options.percent = outlier_percent;
      options.seed = seed;
      options.mode = outlier_mode;
      options.group_size = group_size;
      graph = core::injectOutliersAgainstOptimum(graph, stem, options);
    }
    log = core::logFromGraph(graph, stem);
  }

  PlayerDataset data;
  data.name = log.name.empty() ? stem : log.name;
  data.dimension = log.dimension;
  core::Poses poses;
  for (const core::LogEntry& e : log.entries) {
    PlayerEntry entry;
    switch (e.type) {
      case core::EntryType::kPrior:
        if (e.edge.to != 0 || !poses.empty()) throw std::runtime_error("only a prior on pose 0 is supported");
        entry.type = PlayerEntry::Type::kPose;
        entry.pose = 0;
        entry.odom_pose = e.edge.measurement;
        entry.information = e.edge.information;
        poses.push_back(entry.odom_pose);
        break;
      case core::EntryType::kOdometry:
        if (e.edge.to != static_cast<int>(poses.size()) || e.edge.from != e.edge.to - 1)
          throw std::runtime_error("odometry " + std::to_string(e.edge.from) + " -> " + std::to_string(e.edge.to) +
                                   " is not the next step of the chain");
        entry.type = PlayerEntry::Type::kPose;
        entry.pose = e.edge.to;
        entry.odom_pose = poses.back() * e.edge.measurement;
        entry.information = e.edge.information;
        poses.push_back(entry.odom_pose);
        break;
      case core::EntryType::kLoopClosure:
        entry.type = PlayerEntry::Type::kLoopClosure;
        entry.loop = e.edge;
        ++data.loop_closures;
        if (e.edge.is_outlier) ++data.outliers;
        break;
    }
    data.entries.push_back(entry);
  }
  data.poses = static_cast<int>(poses.size());
  return data;
}

}  // namespace ros_backend
}  // namespace agnc_pgo
