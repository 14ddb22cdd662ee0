// rviz panel agnc_pgo/LoopClosurePanel: the back-end's status, a sortable,
// filterable table of its loop closures (selecting one highlights it in the
// 3-D view on ~selection, a Marker) and buttons for the existing services.
// Thin: rows, sorting, filtering and status text are loop_closure_table.h,
// the service calls backend_commands.h.
#pragma once

#ifndef Q_MOC_RUN
#include <ros/ros.h>
#include <rviz/panel.h>

#include "agnc_pgo/GraphStatus.h"
#include "agnc_pgo/PoseGraph.h"
#include "agnc_pgo/rviz/backend_commands.h"
#include "agnc_pgo/rviz/loop_closure_table.h"
#endif

class QLabel;
class QLineEdit;
class QTableWidget;

namespace agnc_pgo {
namespace panel {

class LoopClosurePanel : public rviz::Panel {
  Q_OBJECT
 public:
  explicit LoopClosurePanel(QWidget* parent = nullptr);
  void onInitialize() override;
  void load(const rviz::Config& config) override;
  void save(rviz::Config config) const override;

 private Q_SLOTS:
  void onFilterChanged(const QString& text);
  void onHeaderClicked(int column);
  void onSelectionChanged();
  void forceInlier();
  void forceOutlier();
  void backToAuto();
  void togglePause();
  void optimize();
  void saveGraph();
  void loadGraph();
  void saveTrajectory();

 private:
  void subscribe();
  void graphCallback(const agnc_pgo::PoseGraph::ConstPtr& graph);
  void statusCallback(const agnc_pgo::GraphStatus::ConstPtr& status);
  void fillTable();
  int selectedLoopIndex() const;
  void setOverride(int mode);
  void report(const CommandOutcome& outcome);

  std::string backend_ = "/agnc_pgo_backend";
  BackendCommands commands_;
  LoopClosureTable table_;
  agnc_pgo::PoseGraph::ConstPtr graph_;
  bool paused_ = false;
  Column sort_column_ = Column::kIndex;
  bool ascending_ = true;
  int sized_at_rows_ = 0;

  ros::NodeHandle nh_;
  ros::Subscriber graph_subscriber_, status_subscriber_;
  ros::Publisher selection_publisher_;

  QLabel* status_label_ = nullptr;
  QLabel* message_label_ = nullptr;
  QLineEdit* filter_edit_ = nullptr;
  QTableWidget* table_widget_ = nullptr;
};

}  // namespace panel
}  // namespace agnc_pgo
