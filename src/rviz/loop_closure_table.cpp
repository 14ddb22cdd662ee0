#include "agnc_pgo/rviz/loop_closure_table.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <sstream>

namespace agnc_pgo {
namespace panel {
namespace {

std::string lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return std::tolower(c); });
  return text;
}

std::string number(double value, const char* format = "%.4g") {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), format, value);
  return buffer;
}

std::string overrideName(uint8_t mode) {
  switch (mode) {
    case agnc_pgo::PoseGraphEdge::FORCE_INLIER: return "force inlier";
    case agnc_pgo::PoseGraphEdge::FORCE_OUTLIER: return "force outlier";
    default: return "auto";
  }
}

// Numbers compare as numbers, the rest as text.
bool less(const LoopClosureRow& a, const LoopClosureRow& b, Column column) {
  switch (column) {
    case Column::kIndex: return a.index < b.index;
    case Column::kFrom: return a.from < b.from;
    case Column::kTo: return a.to < b.to;
    case Column::kFromStamp: return a.from_stamp < b.from_stamp;
    case Column::kToStamp: return a.to_stamp < b.to_stamp;
    case Column::kScore: return a.score < b.score;
    case Column::kMu: return a.mu < b.mu;
    case Column::kWeight: return a.weight < b.weight;
    case Column::kDistance: return a.test_distance < b.test_distance;
    case Column::kThreshold: return a.threshold < b.threshold;
    case Column::kDecided: return a.decided_in_update < b.decided_in_update;
    default: return cellText(a, column) < cellText(b, column);
  }
}

}  // namespace

const char* columnName(Column column) {
  static const char* names[] = {"#", "from", "to", "from stamp", "to stamp", "source", "score", "mu", "weight",
                                "distance", "threshold", "state", "override", "uncorroborated", "decided"};
  return names[static_cast<int>(column)];
}

std::string cellText(const LoopClosureRow& row, Column column) {
  switch (column) {
    case Column::kIndex: return std::to_string(row.index);
    case Column::kFrom: return std::to_string(row.from);
    case Column::kTo: return std::to_string(row.to);
    case Column::kFromStamp: return number(row.from_stamp, "%.3f");
    case Column::kToStamp: return number(row.to_stamp, "%.3f");
    case Column::kSource: return row.source;
    case Column::kScore: return number(row.score);
    case Column::kMu: return number(row.mu);
    case Column::kWeight: return number(row.weight);
    case Column::kDistance: return number(row.test_distance);
    case Column::kThreshold: return number(row.threshold);
    case Column::kState: return row.state;
    case Column::kOverride: return row.override_mode;
    case Column::kUncorroborated: return row.uncorroborated ? "uncorroborated" : "";
    case Column::kDecided: return std::to_string(row.decided_in_update);
    default: return "";
  }
}

std::string stateOf(const agnc_pgo::PoseGraphEdge& edge) {
  if (edge.graduating) return "graduating";
  if (edge.inlier) return "inlier";
  return edge.dormant ? "outlier (dormant)" : "outlier";
}

std::vector<LoopClosureRow> rowsFromGraph(const agnc_pgo::PoseGraph& graph) {
  std::vector<LoopClosureRow> rows;
  for (const auto& e : graph.edges) {
    if (e.type != agnc_pgo::PoseGraphEdge::LOOP_CLOSURE) continue;
    LoopClosureRow row;
    row.index = e.loop_index;
    row.from = static_cast<int>(e.from_id);
    row.to = static_cast<int>(e.to_id);
    if (e.from_id < graph.nodes.size()) row.from_stamp = graph.nodes[e.from_id].stamp.toSec();
    if (e.to_id < graph.nodes.size()) row.to_stamp = graph.nodes[e.to_id].stamp.toSec();
    row.source = e.source;
    row.score = e.score;
    row.mu = e.mu;
    row.weight = e.weight;
    row.test_distance = e.test_distance;
    row.threshold = e.threshold;
    row.state = stateOf(e);
    row.override_mode = overrideName(e.mode);
    row.uncorroborated = e.uncorroborated;
    row.decided_in_update = e.decided_in_update;
    rows.push_back(row);
  }
  std::sort(rows.begin(), rows.end(), [](const LoopClosureRow& a, const LoopClosureRow& b) { return a.index < b.index; });
  return rows;
}

void LoopClosureTable::setRows(std::vector<LoopClosureRow> rows) {
  rows_ = std::move(rows);
  refresh();
}

void LoopClosureTable::sortBy(Column column, bool ascending) {
  sort_column_ = column;
  ascending_ = ascending;
  refresh();
}

void LoopClosureTable::setFilter(const std::string& text) {
  filter_words_.clear();
  std::istringstream words(lower(text));
  for (std::string word; words >> word;) filter_words_.push_back(word);
  refresh();
}

int LoopClosureTable::findLoopIndex(int loop_index) const {
  for (int i = 0; i < size(); ++i)
    if (row(i).index == loop_index) return i;
  return -1;
}

void LoopClosureTable::refresh() {
  visible_.clear();
  for (int i = 0; i < static_cast<int>(rows_.size()); ++i) {
    std::string cells;
    for (int c = 0; c < static_cast<int>(Column::kCount); ++c)
      cells += lower(cellText(rows_[i], static_cast<Column>(c))) + "\t";
    const bool shown = std::all_of(filter_words_.begin(), filter_words_.end(), [&cells](const std::string& w) {
      return cells.find(w) != std::string::npos;
    });
    if (shown) visible_.push_back(i);
  }
  const Column column = sort_column_;
  const bool ascending = ascending_;
  std::stable_sort(visible_.begin(), visible_.end(), [this, column, ascending](int a, int b) {
    return ascending ? less(rows_[a], rows_[b], column) : less(rows_[b], rows_[a], column);
  });
}

std::vector<std::string> statusLines(const agnc_pgo::GraphStatus& s) {
  std::vector<std::string> lines;
  lines.push_back("nodes " + std::to_string(s.nodes) + " | loop closures " + std::to_string(s.loop_closures) + ": " +
                  std::to_string(s.inliers) + " inliers, " + std::to_string(s.outliers) + " outliers, " +
                  std::to_string(s.graduating) + " graduating" + (s.paused ? " | PAUSED" : ""));
  lines.push_back("latency p50 / p95 / max " + number(s.latency_ms_p50, "%.1f") + " / " +
                  number(s.latency_ms_p95, "%.1f") + " / " + number(s.latency_ms_max, "%.1f") +
                  " ms | last update " + number(s.last_update_ms, "%.1f") + " ms, " +
                  std::to_string(s.last_gnc_steps) + " GNC steps");
  lines.push_back("rejected odometry " + std::to_string(s.rejected_odometry) + ", loop closures " +
                  std::to_string(s.rejected_loop_closures) + " (dropped " + std::to_string(s.dropped_loop_closures) +
                  "), failed updates " + std::to_string(s.failed_updates));
  // Zero in a status from before the field existed: as stated.
  if (s.noise_scale_translation > 1.0 || s.noise_scale_rotation > 1.0)
    lines.push_back("covariances widened (noise scale): translation x" + number(s.noise_scale_translation, "%.3g") +
                    ", rotation x" + number(s.noise_scale_rotation, "%.3g"));
  if (!s.last_warning.empty()) lines.push_back("last warning: " + s.last_warning);
  return lines;
}

visualization_msgs::Marker selectionMarker(const agnc_pgo::PoseGraph& graph, int loop_index) {
  visualization_msgs::Marker m;
  m.header.frame_id = graph.header.frame_id;
  m.header.stamp = graph.header.stamp;
  m.ns = "selected_loop_closure";
  m.id = 0;
  m.action = visualization_msgs::Marker::DELETE;
  for (const auto& e : graph.edges) {
    if (e.type != agnc_pgo::PoseGraphEdge::LOOP_CLOSURE || e.loop_index != loop_index) continue;
    if (e.from_id >= graph.nodes.size() || e.to_id >= graph.nodes.size()) break;
    m.action = visualization_msgs::Marker::ADD;
    m.type = visualization_msgs::Marker::LINE_LIST;
    m.pose.orientation.w = 1.0;
    m.scale.x = 0.3;
    m.color.r = 1.0;
    m.color.g = 0.85;
    m.color.a = 1.0;
    geometry_msgs::Point a, b;
    a = graph.nodes[e.from_id].pose.position;
    b = graph.nodes[e.to_id].pose.position;
    m.points = {a, b};
    break;
  }
  return m;
}

}  // namespace panel
}  // namespace agnc_pgo
