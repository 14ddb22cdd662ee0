// An incremental log: the order in which a front-end delivers poses and loop
// closures (ALGORITHM.md §5). Both .irl files and g2o graphs (replayed in pose
// order) become one of these.
#pragma once

#include <string>
#include <vector>

#include "agnc_pgo/core/pose_graph.h"

namespace agnc_pgo {
namespace core {

enum class EntryType { kPrior, kOdometry, kLoopClosure };

struct LogEntry {
  EntryType type = EntryType::kOdometry;
  // kPrior: edge.to is the pose id, edge.measurement its prior value and
  // edge.information its information. Otherwise the edge itself.
  Edge edge;
};

struct IncrementalLog {
  std::string name;
  int dimension = 2;
  std::vector<LogEntry> entries;
  std::vector<int> file_ids;  // as PoseGraph::file_ids: the input file's ids, if not 0..n-1

  int numPoses() const;
  int numLoopClosures() const;
  int numOutliers() const;
};

// Orders a graph as a front-end would deliver it: prior on pose 0, then for
// every k the odometry k -> k+1 followed by every loop closure whose newer
// endpoint is k+1 (in file order). Odometry edges written k+1 -> k are
// inverted. Where no odometry edge joins k and k+1, pose k+1 starts a new
// chain: a prior entry at its value in the graph with information 1e-6 (a
// gauge only; the chain's loop closures attach it to the others).
IncrementalLog logFromGraph(const PoseGraph& graph, const std::string& name);

// Builds the graph a log describes (poses initialised by composing odometry).
PoseGraph graphFromLog(const IncrementalLog& log);

}  // namespace core
}  // namespace agnc_pgo
