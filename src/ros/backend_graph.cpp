#include "agnc_pgo/ros/backend_graph.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "agnc_pgo/ros/conversions.h"

namespace agnc_pgo {
namespace ros_backend {
namespace {

std::string describeStamp(const ros::Time& t) {
  std::ostringstream s;
  s.precision(6);
  s << std::fixed << t.toSec();
  return s.str();
}

bool finitePoses(const core::IncrementalGnc& engine) {
  for (int i = 0; i < engine.numPoses(); ++i) {
    const core::Pose p = engine.pose(i);
    if (!p.translation.allFinite() || !p.rotation.coeffs().allFinite()) return false;
  }
  return true;
}

}  // namespace

BackendGraph::BackendGraph(const BackendParameters& parameters)
    : parameters_(parameters),
      selector_(parameters.keyframes),
      matcher_(parameters.stamp_tolerance) {
  const int t = parameters_.dimension == 2 ? 3 : 6;
  prior_information_ = Eigen::MatrixXd::Identity(t, t) / (parameters_.prior_sigma * parameters_.prior_sigma);
  odometry_information_ = informationFromSigmas(parameters_.odometry_sigmas, parameters_.dimension);
  reset();
}

void BackendGraph::reset() {
  engine_ = std::make_unique<core::IncrementalGnc>(parameters_.dimension, parameters_.gnc);
  selector_.clear();
  matcher_.clear();
  odom_poses_.clear();
  loop_meta_.clear();
  held_.clear();
  accumulated_covariance_.resize(0, 0);
  last_good_ = LastGood();
  decisions_before_overrides_.clear();
  decisions_.clear();
  updates_ = 0;
  has_last_odometry_ = false;
  restarted_.clear();
  carried_iterations_ = carried_gnc_steps_ = 0;
}

std::string BackendGraph::addOdometry(const OdometryInput& input, bool* keyframe) {
  *keyframe = false;
  if (has_last_odometry_) {
    const double jump = (input.pose.translation - last_odometry_position_).norm();
    if (!(jump <= parameters_.max_odometry_jump))
      return "odometry jumps " + std::to_string(jump) + " m since the previous message (limit ~max_odometry_jump " +
             std::to_string(parameters_.max_odometry_jump) + " m)";
  }
  const KeyframeSelector::Decision decision = selector_.consider(input.stamp, input.pose);
  if (decision == KeyframeSelector::Decision::kStampNotIncreasing)
    return "odometry stamp " + describeStamp(input.stamp) + " does not increase (last " +
           describeStamp(selector_.lastStamp()) + ")";

  // Covariance of the motion since the last keyframe (messages' covariance mode).
  if (input.information.size() > 0) {
    const Eigen::MatrixXd cov = covarianceOf(input.information);
    if (accumulated_covariance_.size() == 0) accumulated_covariance_ = cov;
    else accumulated_covariance_ += cov;  // first-order: skipped messages' covariances add up
  }
  if (decision == KeyframeSelector::Decision::kSkip) {
    rememberOdometry(input);
    return "";
  }

  try {
    if (engine_->numPoses() == 0) {
      engine_->addFirstPose(input.pose, prior_information_);
    } else {
      core::Edge edge;
      edge.from = engine_->numPoses() - 1;
      edge.to = engine_->numPoses();
      edge.measurement = odom_poses_.back().inverse() * input.pose;
      edge.kind = core::EdgeKind::kOdometry;
      edge.information = accumulated_covariance_.size() > 0 ? covarianceOf(accumulated_covariance_)
                                                            : odometry_information_;
      engine_->addOdometry(edge);
    }
  } catch (const std::exception& e) {
    // The engine left the graph unchanged; forget this message as a keyframe.
    if (!odom_poses_.empty()) selector_.resetTo(matcher_.stamps().back(), odom_poses_.back());
    else selector_.clear();
    accumulated_covariance_.resize(0, 0);
    return std::string("odometry rejected by the engine: ") + e.what();
  }
  accumulated_covariance_.resize(0, 0);
  matcher_.add(input.stamp);
  odom_poses_.push_back(input.pose);
  last_good_.estimate.push_back(engine_->pose(engine_->numPoses() - 1));
  rememberOdometry(input);
  *keyframe = true;
  return "";
}

void BackendGraph::rememberOdometry(const OdometryInput& input) {
  has_last_odometry_ = true;
  last_odometry_position_ = input.pose.translation;
}

std::string BackendGraph::tryAddLoop(const LoopClosureInput& input, bool* added, bool* hold) {
  *added = false;
  *hold = false;
  const LoopClosureMatcher::Match from = matcher_.match(input.from_stamp);
  const LoopClosureMatcher::Match to = matcher_.match(input.to_stamp);
  using S = LoopClosureMatcher::Status;
  if (from.status == S::kUnknown || to.status == S::kUnknown) {
    const ros::Time& bad = from.status == S::kUnknown ? input.from_stamp : input.to_stamp;
    return "loop closure stamp " + describeStamp(bad) + " matches no keyframe within " +
           std::to_string(parameters_.stamp_tolerance) + " s";
  }
  if (from.status == S::kNotYet || to.status == S::kNotYet) {
    *hold = true;
    return "";
  }
  if (from.id == to.id)
    return "loop closure joins keyframe " + std::to_string(from.id) + " to itself";
  core::Edge edge;
  edge.from = from.id;
  edge.to = to.id;
  edge.measurement = input.measurement;
  edge.information = input.information.size() > 0
                         ? input.information
                         : informationFromSigmas(parameters_.loop_closure_sigmas, parameters_.dimension);
  edge.kind = core::EdgeKind::kLoopClosure;
  edge.is_outlier = input.source == "outlier";  // ground-truth label of the dataset player, if any
  try {
    engine_->addLoopClosure(edge);
  } catch (const std::exception& e) {
    return std::string("loop closure rejected by the engine: ") + e.what();
  }
  loop_meta_.push_back({matcher_.stamp(from.id), matcher_.stamp(to.id), input.source, input.score});
  *added = true;
  return "";
}

std::string BackendGraph::addLoopClosure(const LoopClosureInput& input, bool* added) {
  bool hold = false;
  const std::string warning = tryAddLoop(input, added, &hold);
  if (hold) held_.push_back(input);
  return warning;
}

std::vector<std::string> BackendGraph::retryHeld(double now, std::vector<double>* added_times) {
  std::vector<std::string> warnings;
  std::deque<LoopClosureInput> still;
  for (const LoopClosureInput& input : held_) {
    bool added = false, hold = false;
    const std::string warning = tryAddLoop(input, &added, &hold);
    if (added) {
      added_times->push_back(input.received);
    } else if (hold) {
      if (now - input.received > parameters_.loop_closure_hold_time)
        warnings.push_back("loop closure " + describeStamp(input.from_stamp) + " -> " +
                           describeStamp(input.to_stamp) + " dropped: no keyframe matched within " +
                           std::to_string(parameters_.loop_closure_hold_time) + " s");
      else
        still.push_back(input);
    } else {
      warnings.push_back(warning);
    }
  }
  held_.swap(still);
  return warnings;
}

void BackendGraph::rememberGood() {
  last_good_.estimate = engine_->poses();
  last_good_.loops = engine_->loopStates();
}

void BackendGraph::rollBack() {
  // Rebuild from the edges with the last good estimate; loop closures added
  // since (no good state) are dropped with their metadata.
  SavedGraph saved = save();
  const size_t good_loops = last_good_.loops.size();
  saved.loops.resize(std::min(saved.loops.size(), good_loops));
  core::Poses estimate = last_good_.estimate;
  estimate.resize(std::min(estimate.size(), saved.estimate.size()));
  for (size_t i = estimate.size(); i < saved.estimate.size(); ++i)
    estimate.push_back(estimate[i - 1] * saved.odometry[i - 1].measurement);
  saved.estimate = estimate;
  for (size_t k = 0; k < saved.loops.size(); ++k) saved.loops[k].state = last_good_.loops[k];
  adopt(build(saved));
  loop_meta_.resize(saved.loops.size());
  restarted_.clear();
  rememberGood();
}

bool BackendGraph::guardedSolve(const std::string& what, const std::function<core::UpdateStats()>& solve,
                                core::UpdateStats* stats, std::string* error) {
  try {
    *stats = solve();
    if (!finitePoses(*engine_)) throw std::runtime_error("the estimate became non-finite");
  } catch (const std::exception& e) {
    *error = what + " failed (" + e.what() + "); kept the last good estimate";
    rollBack();
    return false;
  }
  restarted_.clear();
  rememberGood();
  ++updates_;
  noteDecisions();
  idle_refinement_failed_ = false;
  return true;
}

bool BackendGraph::refineIdle(std::string* error) {
  if (idle_refinement_failed_) return false;
  try {
    if (!engine_->refineIdle()) return false;
    if (!finitePoses(*engine_)) throw std::runtime_error("the estimate became non-finite");
  } catch (const std::exception& e) {
    *error = std::string("idle refinement failed (") + e.what() + "); kept the last good estimate";
    rollBack();
    idle_refinement_failed_ = true;
    return false;
  }
  rememberGood();
  noteDecisions();
  return true;
}

void BackendGraph::noteDecisions() {
  const auto& loops = engine_->loopClosures();
  decisions_.resize(std::min(decisions_.size(), loops.size()));
  for (size_t k = 0; k < loops.size(); ++k) {
    const Decision now{loops[k].inlier, loops[k].graduation.graduating, updates_};
    if (k == decisions_.size()) decisions_.push_back(now);
    else if (decisions_[k].inlier != now.inlier || decisions_[k].graduating != now.graduating) decisions_[k] = now;
  }
}

bool BackendGraph::update(core::UpdateStats* stats, std::string* error, const std::function<void()>& first_estimate) {
  return guardedSolve("update", [&] {
    return engine_->update([&] {
      if (first_estimate && finitePoses(*engine_)) first_estimate();
    });
  }, stats, error);
}

bool BackendGraph::optimize(core::UpdateStats* stats, std::string* error) {
  return guardedSolve("optimisation", [this] {
    if (engine_->pendingLoopClosures() > 0) engine_->update();
    return engine_->optimize(parameters_.optimize_iterations);
  }, stats, error);
}

int BackendGraph::setOverride(int index, core::LoopOverride mode) {
  const auto& loops = engine_->loopClosures();
  if (index < 0 || index >= static_cast<int>(loops.size()))
    throw std::invalid_argument("unknown loop closure " + std::to_string(index));
  const auto forced = [&loops] {
    return std::count_if(loops.begin(), loops.end(),
                         [](const core::LoopClosure& l) { return l.override_mode != core::LoopOverride::kAuto; });
  };
  // The automatic decisions before the first of the overrides now in force.
  if (mode != core::LoopOverride::kAuto && forced() == 0) {
    decisions_before_overrides_.clear();
    for (const auto& loop : loops) decisions_before_overrides_.push_back(loop.inlier);
  }
  setEngineOverride(index, mode);
  if (mode != core::LoopOverride::kAuto) return 0;
  int regraduating = 0;
  for (size_t k = 0; k < decisions_before_overrides_.size(); ++k) {
    const core::LoopClosure& loop = loops[k];
    if (static_cast<int>(k) == index || loop.override_mode != core::LoopOverride::kAuto) continue;
    if (loop.inlier == decisions_before_overrides_[k]) continue;
    setEngineOverride(static_cast<int>(k), core::LoopOverride::kAuto);  // restarts its graduation
    ++regraduating;
  }
  if (forced() == 0) decisions_before_overrides_.clear();
  return regraduating;
}

void BackendGraph::setEngineOverride(int index, core::LoopOverride mode) {
  engine_->setOverride(index, mode);
  restarted_.push_back(index);
}

int BackendGraph::findLoopClosure(const ros::Time& from_stamp, const ros::Time& to_stamp) const {
  const LoopClosureMatcher::Match a = matcher_.match(from_stamp);
  const LoopClosureMatcher::Match b = matcher_.match(to_stamp);
  using S = LoopClosureMatcher::Status;
  if (a.status != S::kFound || b.status != S::kFound) return -1;
  const auto& loops = engine_->loopClosures();
  for (size_t k = 0; k < loops.size(); ++k) {
    const core::Edge& e = loops[k].edge;
    if ((e.from == a.id && e.to == b.id) || (e.from == b.id && e.to == a.id)) return static_cast<int>(k);
  }
  return -1;
}

SavedGraph BackendGraph::save() const {
  SavedGraph g;
  g.dimension = parameters_.dimension;
  g.prior_information = prior_information_;
  g.stamps = matcher_.stamps();
  g.odom_poses = odom_poses_;
  g.estimate = engine_->poses();
  g.prior_value = odom_poses_.empty() ? core::Pose() : odom_poses_.front();
  g.odometry = engine_->odometry();
  const auto& loops = engine_->loopClosures();
  const std::vector<core::LoopClosureState> states = engine_->loopStates();
  for (size_t k = 0; k < loops.size(); ++k) {
    SavedLoop l;
    l.edge = loops[k].edge;
    l.state = states[k];
    l.from_stamp = loop_meta_[k].from_stamp;
    l.to_stamp = loop_meta_[k].to_stamp;
    l.source = loop_meta_[k].source;
    l.score = loop_meta_[k].score;
    g.loops.push_back(l);
  }
  return g;
}

std::unique_ptr<core::IncrementalGnc> BackendGraph::build(const SavedGraph& saved) const {
  if (saved.dimension != parameters_.dimension)
    throw std::invalid_argument("the graph is " + std::to_string(saved.dimension) + "D, the back-end runs " +
                                std::to_string(parameters_.dimension) + "D (~dimension)");
  const size_t n = saved.estimate.size();
  if (n == 0 || saved.stamps.size() != n || saved.odom_poses.size() != n)
    throw std::invalid_argument("inconsistent graph: " + std::to_string(n) + " poses");
  for (size_t i = 1; i < n; ++i)
    if (saved.stamps[i] <= saved.stamps[i - 1]) throw std::invalid_argument("keyframe stamps do not increase");
  auto engine = std::make_unique<core::IncrementalGnc>(parameters_.dimension, parameters_.gnc);
  engine->addFirstPose(saved.prior_value, saved.prior_information);
  std::vector<core::Edge> odometry = saved.odometry;
  std::stable_sort(odometry.begin(), odometry.end(),
                   [](const core::Edge& a, const core::Edge& b) { return std::max(a.from, a.to) < std::max(b.from, b.to); });
  for (const core::Edge& e : odometry) engine->addOdometry(e);
  if (engine->numPoses() != static_cast<int>(n))
    throw std::invalid_argument("the odometry chain reaches " + std::to_string(engine->numPoses()) + " of " +
                                std::to_string(n) + " poses");
  for (const SavedLoop& l : saved.loops) engine->addLoopClosure(l.edge);
  if (saved.has_state) {
    std::vector<core::LoopClosureState> states;
    for (const SavedLoop& l : saved.loops) states.push_back(l.state);
    engine->restore(saved.estimate, states);
  }
  return engine;
}

void BackendGraph::adopt(std::unique_ptr<core::IncrementalGnc> engine) {
  carried_iterations_ += engine_->totalIterations();
  carried_gnc_steps_ += engine_->totalGncSteps();
  engine_ = std::move(engine);
}

bool BackendGraph::setParameters(const BackendParameters& next) {
  const bool rebuild = gncOptionsDiffer(parameters_, next);
  const BackendParameters previous = parameters_;
  parameters_ = next;
  try {
    if (rebuild && numNodes() == 0) {
      adopt(std::make_unique<core::IncrementalGnc>(parameters_.dimension, parameters_.gnc));
    } else if (rebuild) {
      SavedGraph saved = save();
      // Restore what was solved; the loop closures that arrived since (paused)
      // are the last ones and stay pending.
      const size_t pending = static_cast<size_t>(engine_->pendingLoopClosures());
      const std::vector<SavedLoop> arrived(saved.loops.end() - pending, saved.loops.end());
      saved.loops.resize(saved.loops.size() - pending);
      saved.has_state = true;
      std::unique_ptr<core::IncrementalGnc> engine = build(saved);
      for (const SavedLoop& l : arrived) engine->addLoopClosure(l.edge);
      for (int index : restarted_) engine->setOverride(index, engine_->loopClosures()[index].override_mode);
      adopt(std::move(engine));
    }
  } catch (...) {
    parameters_ = previous;
    throw;
  }
  matcher_.setTolerance(parameters_.stamp_tolerance);
  return rebuild;
}

void BackendGraph::load(const SavedGraph& saved) {
  std::unique_ptr<core::IncrementalGnc> engine = build(saved);  // throws: graph intact
  reset();
  engine_ = std::move(engine);
  for (const ros::Time& t : saved.stamps) matcher_.add(t);
  odom_poses_ = saved.odom_poses;
  for (const SavedLoop& l : saved.loops) loop_meta_.push_back({l.from_stamp, l.to_stamp, l.source, l.score});
  selector_.resetTo(saved.stamps.back(), saved.odom_poses.back());
  if (saved.has_state) rememberGood();
  else last_good_.estimate = engine_->poses();
}

core::Pose BackendGraph::mapToOdom() const {
  if (odom_poses_.empty()) return core::Pose();
  const int last = engine_->numPoses() - 1;
  return engine_->pose(last) * odom_poses_[last].inverse();
}

GraphSnapshotPtr BackendGraph::snapshot(bool with_edges) const {
  auto s = std::make_shared<GraphSnapshot>();
  s->dimension = parameters_.dimension;
  s->map_to_odom = mapToOdom();
  const int n = engine_->numPoses();
  s->nodes.resize(n);
  for (int i = 0; i < n; ++i) {
    s->nodes[i].stamp = matcher_.stamp(i);
    s->nodes[i].pose = engine_->pose(i);
    s->nodes[i].odom_pose = odom_poses_[i];
  }
  if (!with_edges || n == 0) return s;
  s->has_edges = true;
  SnapshotEdge prior;
  prior.type = SnapshotEdgeType::kPrior;
  prior.measurement = odom_poses_.front();
  prior.information = prior_information_;
  s->edges.push_back(prior);
  for (const core::Edge& e : engine_->odometry()) {
    SnapshotEdge edge;
    edge.type = SnapshotEdgeType::kOdometry;
    edge.from = e.from;
    edge.to = e.to;
    edge.measurement = e.measurement;
    edge.information = e.information;
    s->edges.push_back(edge);
  }
  const auto& loops = engine_->loopClosures();
  const int first_pending = static_cast<int>(loops.size()) - engine_->pendingLoopClosures();
  for (size_t k = 0; k < loops.size(); ++k) {
    const core::LoopClosure& l = loops[k];
    SnapshotEdge edge;
    edge.type = SnapshotEdgeType::kLoopClosure;
    edge.from = l.edge.from;
    edge.to = l.edge.to;
    edge.loop_index = static_cast<int>(k);
    edge.measurement = l.edge.measurement;
    edge.information = l.edge.information;
    edge.mu = l.graduation.mu;
    edge.weight = l.weight;
    edge.distance = l.distance;
    edge.inlier = l.inlier;
    edge.graduating = l.graduation.graduating || static_cast<int>(k) >= first_pending;
    edge.mode = l.override_mode;
    edge.source = loop_meta_[k].source;
    edge.score = loop_meta_[k].score;
    edge.test_distance = engine_->schedule().classificationDistance(l.distance);
    edge.threshold = engine_->schedule().thresholds().q95;
    edge.uncorroborated = l.uncorroborated;
    edge.dormant = l.dormant;
    edge.decided_in_update = k < decisions_.size() ? decisions_[k].update : updates_;
    s->edges.push_back(edge);
  }
  return s;
}

}  // namespace ros_backend
}  // namespace agnc_pgo
