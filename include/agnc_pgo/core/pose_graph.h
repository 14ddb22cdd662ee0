// The pose graph as plain data: poses (by contiguous 0-based index), relative
// pose edges with full information matrices, and the dimension (2 or 3).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "agnc_pgo/core/pose.h"

namespace agnc_pgo {
namespace core {

enum class EdgeKind { kOdometry, kLoopClosure };

struct Edge {
  int from = 0;  // i
  int to = 0;    // j
  Pose measurement;                 // pose of j in the frame of i
  Eigen::MatrixXd information;      // 3x3 (x y theta) or 6x6 (x y z rx ry rz), g2o order
  EdgeKind kind = EdgeKind::kLoopClosure;
  bool is_outlier = false;          // ground-truth label (injected / from .irl); false if unknown
};

struct PoseGraph {
  int dimension = 2;                // 2 for SE(2), 3 for SE(3)
  std::vector<Pose, Eigen::aligned_allocator<Pose>> poses;  // index = id
  std::vector<Edge> edges;
  std::vector<int> fixed;           // ids marked FIX (the gauge); empty = fix pose 0
  // The id a file gave each pose, where those are not 0..n-1 (a g2o file
  // whose ids skip values: readG2o numbers its poses in id order, writeG2o
  // writes these back). Empty: pose i is id i. Strictly increasing.
  std::vector<int> file_ids;
  int fileId(int index) const { return file_ids.empty() ? index : file_ids[index]; }

  int tangentDimension() const { return dimension == 2 ? 3 : 6; }
  int numLoopClosures() const;
  int numOutliers() const;
};

// Classifies an edge between ids i and j: |i - j| == 1 is odometry.
EdgeKind classifyEdge(int from, int to);

// Re-initialises every pose by composing odometry from pose 0 (or its
// current value), for files without vertices. Throws std::runtime_error if a
// pose cannot be reached through the odometry chain.
void initializeFromOdometry(PoseGraph* graph);

}  // namespace core
}  // namespace agnc_pgo
