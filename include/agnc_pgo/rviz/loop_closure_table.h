// What the rviz panel shows, as plain classes (no Qt): the rows of the loop
// closure table made from ~pose_graph, their sorting and filtering, the
// status lines from ~status, and the marker that highlights a selected loop
// closure. The panel (loop_closure_panel.h) only puts these on screen.
#pragma once

#include <string>
#include <vector>

#include <visualization_msgs/Marker.h>

#include "agnc_pgo/GraphStatus.h"
#include "agnc_pgo/PoseGraph.h"

namespace agnc_pgo {
namespace panel {

struct LoopClosureRow {
  int index = -1;              // PoseGraphEdge.loop_index (for ~set_loop_closure_status)
  int from = 0, to = 0;        // node ids
  double from_stamp = 0, to_stamp = 0;  // [s] the keyframes' stamps
  std::string source;
  double score = 0;
  double mu = 0, weight = 0;
  double test_distance = 0, threshold = 0;  // what GNC compared (inlier iff test_distance < threshold)
  std::string state;           // "inlier", "outlier", "outlier (dormant)", "graduating"
  std::string override_mode;   // "auto", "force inlier", "force outlier"
  bool uncorroborated = false;
  long decided_in_update = 0;
};

enum class Column {
  kIndex, kFrom, kTo, kFromStamp, kToStamp, kSource, kScore, kMu, kWeight, kDistance, kThreshold, kState,
  kOverride, kUncorroborated, kDecided, kCount
};

const char* columnName(Column column);
std::string cellText(const LoopClosureRow& row, Column column);

// The state word of a loop-closure edge.
std::string stateOf(const agnc_pgo::PoseGraphEdge& edge);
// One row per loop-closure edge, in loop-index order.
std::vector<LoopClosureRow> rowsFromGraph(const agnc_pgo::PoseGraph& graph);

// The rows on screen: sorted by one column, filtered by a text.
class LoopClosureTable {
 public:
  // Replaces the rows; the sort order and the filter stay.
  void setRows(std::vector<LoopClosureRow> rows);
  void sortBy(Column column, bool ascending);
  // Case-insensitive: a row is shown when any of its cells contains every
  // word of `text` ("outlier true": true loop closures rejected). Empty:
  // every row.
  void setFilter(const std::string& text);

  int size() const { return static_cast<int>(visible_.size()); }
  int total() const { return static_cast<int>(rows_.size()); }
  const LoopClosureRow& row(int visible_row) const { return rows_[visible_[visible_row]]; }
  // The visible row showing loop closure `loop_index`, or -1.
  int findLoopIndex(int loop_index) const;

 private:
  void refresh();
  std::vector<LoopClosureRow> rows_;
  std::vector<int> visible_;  // indices into rows_, sorted and filtered
  Column sort_column_ = Column::kIndex;
  bool ascending_ = true;
  std::vector<std::string> filter_words_;
};

// "nodes 3500 | loop closures 2332: 2099 inliers, 233 outliers, 0 graduating", ...
std::vector<std::string> statusLines(const agnc_pgo::GraphStatus& status);

// A thick yellow line between the loop closure's two nodes (and a sphere at
// each), in the graph's frame; action DELETE when the index is not in it.
visualization_msgs::Marker selectionMarker(const agnc_pgo::PoseGraph& graph, int loop_index);

}  // namespace panel
}  // namespace agnc_pgo
