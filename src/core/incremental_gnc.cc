#include "agnc_pgo/core/incremental_gnc.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "agnc_pgo/core/loop_consistency.h"
#include "agnc_pgo/core/shape_function.h"

namespace agnc_pgo {
namespace core {
namespace {

// Plain least squares needs more iterations than a warm-started GNC step:
// without graduation, a loop closure's whole correction lands at once.
constexpr int kMinPlainIterations = 10;

// The step size that decides convergence: a step the trust region cut short
// says nothing about it.
double convergenceStep(const IterationResult& r) {
  return r.truncated ? std::numeric_limits<double>::infinity() : r.mean_step;
}

// How far a pose moved: the norm of (translation, rotation angle), a stand-in
// for the tangent-space norm of the step that took it there.
double displacement(const Pose& before, const Pose& after) {
  const Pose d = before.inverse() * after;
  return std::hypot(d.translation.norm(), d.rotation.angularDistance(Eigen::Quaterniond::Identity()));
}

bool finiteEdge(const Edge& e) {
  return e.measurement.translation.allFinite() && e.measurement.rotation.coeffs().allFinite() &&
         e.information.allFinite();
}

}  // namespace

IncrementalGnc::IncrementalGnc(int dimension, const GncOptions& options)
    : dimension_(dimension),
      options_(options),
      schedule_(options, dimension == 2 ? 3 : 6),
      solver_(dimension, options.shape_c) {
  validate(options_);
  solver_.setTrustRegion(options_.trust_region, options_.trust_region_radius,
                         options_.max_trust_region_radius);
}

void IncrementalGnc::addFirstPose(const Pose& value, const Eigen::MatrixXd& information) {
  if (numPoses() != 0) throw std::invalid_argument("the first pose exists already");
  solver_.addPose(value);
  solver_.addFactor(SparsePoseGraphSolver::kAnchor, 0, value, information, FactorMode::kPlain);
}

void IncrementalGnc::validateEdge(const Edge& e, bool allow_new_pose) const {
  const int n = numPoses();
  const bool from_ok = e.from >= 0 && e.from < n;
  const bool to_ok = (e.to >= 0 && e.to < n) || (allow_new_pose && e.to == n);
  if (!from_ok || !to_ok || e.from == e.to)
    throw std::invalid_argument("edge " + std::to_string(e.from) + " -> " + std::to_string(e.to) +
                                " refers to an unknown pose (graph has " + std::to_string(n) +
                                " poses)");
  if (!finiteEdge(e)) throw std::invalid_argument("edge contains NaN or Inf");
  if (e.measurement.rotation.norm() < 1e-9) throw std::invalid_argument("zero quaternion");
  const int dim = dimension_ == 2 ? 3 : 6;
  if (e.information.rows() != dim || e.information.cols() != dim)
    throw std::invalid_argument("information must be " + std::to_string(dim) + "x" +
                                std::to_string(dim));
  sqrtInformation(e.information);  // throws if not positive definite
}

void IncrementalGnc::addOdometry(const Edge& edge) {
  validateEdge(edge, /*allow_new_pose=*/true);
  if (edge.to == numPoses()) solver_.addPose(solver_.pose(edge.from) * edge.measurement);
  solver_.addFactor(edge.from, edge.to, edge.measurement, edge.information, FactorMode::kPlain);
  odometry_.push_back(edge);
}

int IncrementalGnc::addLoopClosure(const Edge& edge) {
  validateEdge(edge, /*allow_new_pose=*/false);
  LoopClosure loop;
  loop.edge = edge;
  loop.edge.kind = EdgeKind::kLoopClosure;
  const FactorMode mode =
      options_.schedule == ScheduleKind::kNone ? FactorMode::kPlain : FactorMode::kRobust;
  loop.factor = solver_.addFactor(edge.from, edge.to, edge.measurement, edge.information, mode);
  loops_.push_back(loop);
  const int index = static_cast<int>(loops_.size()) - 1;
  const int newer = std::max(edge.from, edge.to);
  if (static_cast<int>(loops_by_newer_pose_.size()) <= newer) loops_by_newer_pose_.resize(newer + 1);
  loops_by_newer_pose_[newer].push_back(index);
  findSupport(index);
  pending_.push_back(index);
  return index;
}

void IncrementalGnc::findSupport(int index) {
  const int radius = options_.support_radius;
  if (radius == 0) return;
  LoopClosure& loop = loops_[index];
  const int newer = std::max(loop.edge.from, loop.edge.to);
  const int last = std::min(newer + radius, static_cast<int>(loops_by_newer_pose_.size()) - 1);
  const auto pose = [this](int id) { return solver_.pose(id); };
  for (int p = std::max(0, newer - radius); p <= last; ++p) {
    for (int other : loops_by_newer_pose_[p]) {
      if (other == index || !areNeighbours(loop.edge, loops_[other].edge, radius)) continue;
      const double d = cycleDistance(dimension_, loop.edge, loops_[other].edge, pose);
      if (!schedule_.isInlier(schedule_.distanceOf(d))) continue;
      loop.supported = true;
      loops_[other].supported = true;
    }
  }
}

Poses IncrementalGnc::poses() const {
  Poses out;
  out.reserve(numPoses());
  for (int i = 0; i < numPoses(); ++i) out.push_back(solver_.pose(i));
  return out;
}

void IncrementalGnc::refresh(LoopClosure* loop) {
  loop->distance = solver_.whitenedNorm(loop->factor);
  loop->weight = solver_.weight(loop->factor);
  switch (loop->override_mode) {
    case LoopOverride::kForceInlier: loop->inlier = true; break;
    case LoopOverride::kForceOutlier: loop->inlier = false; break;
    case LoopOverride::kAuto:
      loop->inlier = schedule_.isInlier(schedule_.distanceOf(loop->distance));
      break;
  }
  const bool rejected_at_one = loop->override_mode == LoopOverride::kAuto &&
                               options_.schedule != ScheduleKind::kNone && !loop->graduation.graduating &&
                               loop->graduation.mu >= 1.0;
  setSparsity(loop, rejected_at_one && loop->weight < dormantWeight(*loop),
              rejected_at_one && loop->weight < options_.decoupled_weight);
}

void IncrementalGnc::setSparsity(LoopClosure* loop, bool dormant, bool decoupled) {
  loop->dormant = dormant;
  solver_.setDormant(loop->factor, dormant);
  solver_.setDecoupled(loop->factor, decoupled);
}

bool IncrementalGnc::staysDormant(const LoopClosure& loop) const {
  if (!loop.dormant) return false;
  // A restart that begins at mu = 1 would graduate it at the weight it has
  // now; if that is still negligible, graduating it changes nothing.
  const GraduationState& g = loop.graduation;
  const bool restarts_at_one = options_.schedule == ScheduleKind::kRisam
                                   ? g.mu_init >= 1.0
                                   : g.init_step >= ShapeFunction::kStepsToOne;
  return restarts_at_one && solver_.weight(loop.factor) < dormantWeight(loop);
}

double IncrementalGnc::dormantWeight(const LoopClosure& loop) const {
  return loop.supported ? options_.supported_dormant_weight : options_.dormant_weight;
}

void IncrementalGnc::classifyAll() {
  for (LoopClosure& loop : loops_) refresh(&loop);
}

void IncrementalGnc::applyOverride(LoopClosure* loop) {
  switch (loop->override_mode) {
    case LoopOverride::kForceInlier: solver_.setMode(loop->factor, FactorMode::kPlain); break;
    case LoopOverride::kForceOutlier: solver_.setMode(loop->factor, FactorMode::kDisabled); break;
    case LoopOverride::kAuto:
      solver_.setMode(loop->factor, options_.schedule == ScheduleKind::kNone
                                        ? FactorMode::kPlain
                                        : FactorMode::kRobust);
      break;
  }
  loop->graduation.graduating = false;
  // Back in the linear system until the next classification says otherwise.
  setSparsity(loop, false, false);
}

void IncrementalGnc::setOverride(int index, LoopOverride mode) {
  if (index < 0 || index >= static_cast<int>(loops_.size()))
    throw std::invalid_argument("unknown loop closure " + std::to_string(index));
  loops_[index].override_mode = mode;
  applyOverride(&loops_[index]);
  needs_restart_.push_back(index);
}

void IncrementalGnc::acceptConsistent(const std::vector<int>& graduating) {
  for (int index : graduating) {
    LoopClosure& loop = loops_[index];
    if (!loop.graduation.graduating) continue;
    const double m = schedule_.distanceOf(solver_.whitenedNorm(loop.factor));
    if (m >= schedule_.thresholds().q25) continue;
    acceptAsInlier(&loop);
  }
}

void IncrementalGnc::acceptAsInlier(LoopClosure* loop) {
  loop->graduation.mu = 1.0;
  loop->graduation.graduating = false;
  solver_.setMu(loop->factor, 1.0);
}

IterationResult IncrementalGnc::iterateOnce(int first, UpdateStats* stats) {
  const IterationResult r = solver_.iterate(first);
  ++stats->iterations;
  stats->factorizations += r.factorizations;
  if (r.accepted) {
    stats->max_mean_step = std::max(stats->max_mean_step, r.mean_step);
  }
  return r;
}

int IncrementalGnc::settle(int first, int max_iterations, double last_step, UpdateStats* stats) {
  int done = 0;
  while (done < max_iterations && last_step >= options_.convergence_step) {
    const IterationResult r = iterateOnce(first, stats);
    ++done;
    if (!r.accepted) break;  // nothing reduces the cost: converged as far as we can go
    last_step = convergenceStep(r);
  }
  stats->converged = last_step < options_.convergence_step;
  return done;
}

UpdateStats IncrementalGnc::update() {
  UpdateStats stats;
  if (pending_.empty() && needs_restart_.empty()) return stats;
  // Every update starts with a small trust region that grows only while the
  // steps agree with the model (see GncOptions::restart_trust_region).
  if (options_.restart_trust_region) solver_.setTrustRegionRadius(options_.trust_region_radius);

  // The oldest pose a new loop closure (or changed override) touches, and
  // the free window: from that pose on, but reaching at most
  // max_window_poses poses back from each loop closure's newer endpoint (the
  // older endpoint of a long loop closure is then held fixed with the rest of
  // the old map, see GncOptions::max_window_poses).
  int oldest = numPoses(), first = numPoses();
  auto reach = [&](const Edge& e) {
    const int older = std::min(e.from, e.to), newer = std::max(e.from, e.to);
    oldest = std::min(oldest, older);
    first = std::min(first, options_.max_window_poses > 0
                                ? std::max(older, newer + 1 - options_.max_window_poses)
                                : older);
  };
  for (int index : pending_) reach(loops_[index].edge);
  for (int index : needs_restart_) reach(loops_[index].edge);
  if (!options_.local_window) first = 0;
  stats.first_variable = first;

  // Select what graduates: the new loop closures, then the reset policy.
  std::vector<int> graduating, still_dormant;
  std::vector<char> selected(loops_.size(), 0);
  auto select = [&](int index) {
    LoopClosure& loop = loops_[index];
    if (selected[index] || loop.override_mode != LoopOverride::kAuto) return;
    selected[index] = 1;
    if (staysDormant(loop)) {
      still_dormant.push_back(index);
      return;
    }
    setSparsity(&loop, false, false);
    schedule_.start(&loop.graduation);
    if (loop.graduation.graduating) graduating.push_back(index);
  };
  std::vector<int> touched;
  bool all_consistent = needs_restart_.empty();
  for (int index : pending_) {
    LoopClosure& loop = loops_[index];
    if (options_.accept_consistent_on_arrival && loop.override_mode == LoopOverride::kAuto &&
        options_.schedule != ScheduleKind::kNone &&
        schedule_.distanceOf(solver_.whitenedNorm(loop.factor)) < schedule_.thresholds().q25) {
      selected[index] = 1;
      schedule_.start(&loop.graduation);
      acceptAsInlier(&loop);
      touched.push_back(index);
      continue;
    }
    all_consistent = false;
    select(index);
  }
  for (int index : needs_restart_) select(index);
  if (options_.reset != ResetPolicy::kNone && !all_consistent) {
    for (int index = 0; index < static_cast<int>(loops_.size()); ++index) {
      const Edge& e = loops_[index].edge;
      // A loop closure with both ends held fixed cannot move in this update.
      if (options_.reset == ResetPolicy::kAll || std::max(e.from, e.to) >= std::max(oldest, first))
        select(index);
    }
  }
  touched.insert(touched.end(), graduating.begin(), graduating.end());
  stats.graduated = static_cast<int>(graduating.size());

  // Where the window starts from: the whole-graph refinement below is
  // decided on how far the update moved it.
  const bool may_refine = first > 0 && options_.global_refinement;
  Poses window_before;
  if (may_refine) {
    window_before.reserve(numPoses() - first);
    for (int i = first; i < numPoses(); ++i) window_before.push_back(solver_.pose(i));
  }

  // GNC steps: set mu for every graduating loop closure, then one iteration.
  double last_step = std::numeric_limits<double>::infinity();
  while (!graduating.empty() && stats.gnc_steps < options_.max_gnc_steps) {
    for (int index : graduating) {
      LoopClosure& loop = loops_[index];
      const double r = solver_.whitenedNorm(loop.factor);
      schedule_.advance(&loop.graduation, schedule_.distanceOf(r));
      solver_.setMu(loop.factor, loop.graduation.mu);
    }
    IterationResult r = iterateOnce(first, &stats);
    for (int extra = 1; extra < options_.iterations_per_step && r.accepted &&
                        r.mean_step >= options_.convergence_step;
         ++extra)
      r = iterateOnce(first, &stats);
    ++stats.gnc_steps;
    if (r.accepted) last_step = convergenceStep(r);
    for (int index : graduating) schedule_.finishStep(&loops_[index].graduation);
    if (options_.early_accept_consistent && r.accepted && !r.truncated &&
        r.mean_step < options_.convergence_step)
      acceptConsistent(graduating);
    graduating.erase(std::remove_if(graduating.begin(), graduating.end(),
                                    [this](int i) { return !loops_[i].graduation.graduating; }),
                     graduating.end());
  }

  const int max_settle = options_.schedule == ScheduleKind::kNone
                             ? std::max(options_.max_settle_iterations, kMinPlainIterations)
                             : options_.max_settle_iterations;
  settle(first, max_settle, last_step, &stats);
  // The window held older poses fixed. If the update moved the estimate, let
  // the whole graph follow (the correction belongs to every pose, not only to
  // those in the window). "Moved" is judged as a whole-graph solve would be --
  // the mean displacement over all poses -- and small corrections add up
  // across updates: the refinement runs once those since the last one amount
  // to convergence_step, so a window that shifted a little does not cost
  // whole-graph iterations every time. The displacement is net: an outlier
  // that pulled the window at a small mu and was then rejected moved it
  // there and back, which calls for no refinement.
  if (first == 0) unrefined_step_ = 0.0;
  if (may_refine)
    for (int i = first; i < numPoses(); ++i)
      unrefined_step_ += displacement(window_before[i - first], solver_.pose(i));
  if (may_refine && unrefined_step_ / numPoses() >= options_.convergence_step) {
    const int before = stats.iterations;
    settle(0, max_settle, std::numeric_limits<double>::infinity(), &stats);
    stats.refinement_iterations = stats.iterations - before;
    unrefined_step_ = 0.0;
  }

  for (int index : touched) {
    LoopClosure& loop = loops_[index];
    refresh(&loop);
    if (stats.converged) schedule_.adaptInitial(&loop.graduation, schedule_.distanceOf(loop.distance));
  }
  // Skipped as dormant: did the estimate move towards one of them?
  for (int index : still_dormant) refresh(&loops_[index]);
  // Not graduating but changed: schedule none, or an override.
  for (int index : pending_) refresh(&loops_[index]);
  for (int index : needs_restart_) refresh(&loops_[index]);

  pending_.clear();
  needs_restart_.clear();
  total_iterations_ += stats.iterations;
  total_gnc_steps_ += stats.gnc_steps;
  return stats;
}

UpdateStats IncrementalGnc::optimize(int max_iterations) {
  UpdateStats stats;
  settle(0, max_iterations, std::numeric_limits<double>::infinity(), &stats);
  classifyAll();
  total_iterations_ += stats.iterations;
  return stats;
}

}  // namespace core
}  // namespace agnc_pgo
