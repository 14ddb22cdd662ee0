#include "agnc_pgo/rviz/loop_closure_panel.h"

#include <QFileDialog>
#include <QHBoxLayout>
#include <QHeaderView>
#include <QLabel>
#include <QLineEdit>
#include <QPushButton>
#include <QTableWidget>
#include <QVBoxLayout>

#include <pluginlib/class_list_macros.hpp>

#include "agnc_pgo/SetLoopClosureStatus.h"

namespace agnc_pgo {
namespace panel {
namespace {

QPushButton* button(const char* text, QWidget* parent, QLayout* layout) {
  auto* b = new QPushButton(text, parent);
  layout->addWidget(b);
  return b;
}

}  // namespace

LoopClosurePanel::LoopClosurePanel(QWidget* parent) : rviz::Panel(parent) {
  auto* layout = new QVBoxLayout(this);
  status_label_ = new QLabel("waiting for " + QString::fromStdString(backend_) + "/status", this);
  status_label_->setWordWrap(true);
  layout->addWidget(status_label_);

  filter_edit_ = new QLineEdit(this);
  filter_edit_->setPlaceholderText("filter: words every shown row contains, e.g. \"outlier true\"");
  layout->addWidget(filter_edit_);

  table_widget_ = new QTableWidget(this);
  table_widget_->setColumnCount(static_cast<int>(Column::kCount));
  QStringList headers;
  for (int c = 0; c < static_cast<int>(Column::kCount); ++c) headers << columnName(static_cast<Column>(c));
  table_widget_->setHorizontalHeaderLabels(headers);
  table_widget_->setSelectionBehavior(QAbstractItemView::SelectRows);
  table_widget_->setSelectionMode(QAbstractItemView::SingleSelection);
  table_widget_->setEditTriggers(QAbstractItemView::NoEditTriggers);
  table_widget_->verticalHeader()->setVisible(false);
  table_widget_->verticalHeader()->setDefaultSectionSize(table_widget_->fontMetrics().height() + 4);
  table_widget_->setWordWrap(false);
  table_widget_->horizontalHeader()->setSectionsClickable(true);
  layout->addWidget(table_widget_, 1);

  auto* overrides = new QHBoxLayout();
  connect(button("Force inlier", this, overrides), SIGNAL(clicked()), this, SLOT(forceInlier()));
  connect(button("Force outlier", this, overrides), SIGNAL(clicked()), this, SLOT(forceOutlier()));
  connect(button("Automatic", this, overrides), SIGNAL(clicked()), this, SLOT(backToAuto()));
  layout->addLayout(overrides);
  auto* graph = new QHBoxLayout();
  connect(button("Pause/resume", this, graph), SIGNAL(clicked()), this, SLOT(togglePause()));
  connect(button("Optimise", this, graph), SIGNAL(clicked()), this, SLOT(optimize()));
  connect(button("Save graph", this, graph), SIGNAL(clicked()), this, SLOT(saveGraph()));
  connect(button("Load graph", this, graph), SIGNAL(clicked()), this, SLOT(loadGraph()));
  connect(button("Save trajectory", this, graph), SIGNAL(clicked()), this, SLOT(saveTrajectory()));
  layout->addLayout(graph);
  message_label_ = new QLabel(this);
  message_label_->setWordWrap(true);
  layout->addWidget(message_label_);

  connect(filter_edit_, SIGNAL(textChanged(const QString&)), this, SLOT(onFilterChanged(const QString&)));
  connect(table_widget_->horizontalHeader(), SIGNAL(sectionClicked(int)), this, SLOT(onHeaderClicked(int)));
  connect(table_widget_, SIGNAL(itemSelectionChanged()), this, SLOT(onSelectionChanged()));
}

void LoopClosurePanel::onInitialize() { subscribe(); }

void LoopClosurePanel::subscribe() {
  commands_ = BackendCommands(backend_);
  // rviz spins the global callback queue in its GUI thread: the callbacks may touch the widgets.
  graph_subscriber_ = nh_.subscribe(backend_ + "/pose_graph", 1, &LoopClosurePanel::graphCallback, this);
  status_subscriber_ = nh_.subscribe(backend_ + "/status", 1, &LoopClosurePanel::statusCallback, this);
  selection_publisher_ = nh_.advertise<visualization_msgs::Marker>(backend_ + "_panel/selection", 1, true);
}

void LoopClosurePanel::load(const rviz::Config& config) {
  rviz::Panel::load(config);
  QString backend;
  if (config.mapGetString("Backend", &backend) && !backend.isEmpty()) {
    backend_ = backend.toStdString();
    subscribe();
  }
  QString filter;
  if (config.mapGetString("Filter", &filter)) filter_edit_->setText(filter);
}

void LoopClosurePanel::save(rviz::Config config) const {
  rviz::Panel::save(config);
  config.mapSetValue("Backend", QString::fromStdString(backend_));
  config.mapSetValue("Filter", filter_edit_->text());
}

void LoopClosurePanel::graphCallback(const agnc_pgo::PoseGraph::ConstPtr& graph) {
  graph_ = graph;
  table_.setRows(rowsFromGraph(*graph));
  fillTable();
}

void LoopClosurePanel::statusCallback(const agnc_pgo::GraphStatus::ConstPtr& status) {
  paused_ = status->paused;
  QString text;
  for (const std::string& line : statusLines(*status)) text += QString::fromStdString(line) + "\n";
  status_label_->setText(text.trimmed());
}

void LoopClosurePanel::fillTable() {
  const int selected = selectedLoopIndex();
  table_widget_->blockSignals(true);
  table_widget_->setRowCount(table_.size());
  for (int r = 0; r < table_.size(); ++r) {
    for (int c = 0; c < static_cast<int>(Column::kCount); ++c) {
      QTableWidgetItem* item = table_widget_->item(r, c);
      if (!item) table_widget_->setItem(r, c, item = new QTableWidgetItem());
      item->setText(QString::fromStdString(cellText(table_.row(r), static_cast<Column>(c))));
    }
  }
  // Sized to the contents whenever the table has grown tenfold (wider
  // numbers), not on every graph: that would undo the user's widths.
  if (table_.size() > 0 && table_.size() >= 10 * sized_at_rows_) {
    table_widget_->resizeColumnsToContents();
    sized_at_rows_ = table_.size();
  }
  const int row = selected < 0 ? -1 : table_.findLoopIndex(selected);
  if (row >= 0) table_widget_->selectRow(row);
  else table_widget_->clearSelection();
  table_widget_->blockSignals(false);
  onSelectionChanged();  // the highlighted loop closure follows the graph's estimate
}

int LoopClosurePanel::selectedLoopIndex() const {
  const auto rows = table_widget_->selectionModel()->selectedRows();
  if (rows.isEmpty() || rows.front().row() >= table_.size()) return -1;
  return table_.row(rows.front().row()).index;
}

void LoopClosurePanel::onFilterChanged(const QString& text) {
  table_.setFilter(text.toStdString());
  fillTable();
}

void LoopClosurePanel::onHeaderClicked(int column) {
  const Column c = static_cast<Column>(column);
  ascending_ = c == sort_column_ ? !ascending_ : true;
  sort_column_ = c;
  table_.sortBy(sort_column_, ascending_);
  fillTable();
}

void LoopClosurePanel::onSelectionChanged() {
  if (!graph_) return;
  selection_publisher_.publish(selectionMarker(*graph_, selectedLoopIndex()));
}

void LoopClosurePanel::setOverride(int mode) {
  const int index = selectedLoopIndex();
  if (index < 0) return report({false, "select a loop closure first"});
  report(commands_.setOverride(index, mode));
}

void LoopClosurePanel::forceInlier() { setOverride(agnc_pgo::SetLoopClosureStatus::Request::FORCE_INLIER); }
void LoopClosurePanel::forceOutlier() { setOverride(agnc_pgo::SetLoopClosureStatus::Request::FORCE_OUTLIER); }
void LoopClosurePanel::backToAuto() { setOverride(agnc_pgo::SetLoopClosureStatus::Request::AUTO); }
void LoopClosurePanel::togglePause() { report(commands_.pause(!paused_)); }
void LoopClosurePanel::optimize() { report(commands_.optimize()); }

void LoopClosurePanel::saveGraph() {
  const QString file = QFileDialog::getSaveFileName(this, "Save graph", "graph.g2o", "g2o (*.g2o)");
  if (!file.isEmpty()) report(commands_.saveGraph(file.toStdString()));
}

void LoopClosurePanel::loadGraph() {
  const QString file = QFileDialog::getOpenFileName(this, "Load graph", "", "g2o (*.g2o)");
  if (!file.isEmpty()) report(commands_.loadGraph(file.toStdString()));
}

void LoopClosurePanel::saveTrajectory() {
  const QString file = QFileDialog::getSaveFileName(this, "Save trajectory", "trajectory.tum", "TUM (*.tum *.txt)");
  if (!file.isEmpty()) report(commands_.saveTrajectory(file.toStdString()));
}

void LoopClosurePanel::report(const CommandOutcome& outcome) {
  message_label_->setText(QString::fromStdString((outcome.success ? "" : "failed: ") + outcome.message));
}

}  // namespace panel
}  // namespace agnc_pgo

PLUGINLIB_EXPORT_CLASS(agnc_pgo::panel::LoopClosurePanel, rviz::Panel)
