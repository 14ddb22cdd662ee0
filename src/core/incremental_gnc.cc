#include "agnc_pgo/core/incremental_gnc.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <numeric>
#include <stdexcept>
#include <string>

#include "agnc_pgo/core/loop_consistency.h"
#include "agnc_pgo/core/loop_prediction.h"
#include "agnc_pgo/core/shape_function.h"
#include "incremental_gnc_internal.h"

namespace agnc_pgo {
namespace core {
namespace {

using internal::convergenceStep;
using internal::newerEnd;
using internal::olderEnd;

// Idle refinement, and each stage of an idle check: iterations at most, as
// optimize()'s default. They stop earlier at convergence
// (convergence_step); the bound only ends one whose steps keep crossing the
// inlier gate.
constexpr int kMaxIdleIterations = 20;

// Plain least squares needs more iterations than a warm-started GNC step:
// without graduation, a loop closure's whole correction lands at once.
constexpr int kMinPlainIterations = 10;

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

// The statistics of two passes of one update.
UpdateStats combined(const UpdateStats& a, const UpdateStats& b) {
  UpdateStats out;
  out.gnc_steps = a.gnc_steps + b.gnc_steps;
  out.iterations = a.iterations + b.iterations;
  out.refinement_iterations = a.refinement_iterations + b.refinement_iterations;
  out.graduated = a.graduated + b.graduated;
  out.first_variable = std::min(a.first_variable, b.first_variable);
  out.converged = b.converged;
  return out;
}

}  // namespace

IncrementalGnc::IncrementalGnc(int dimension, const GncOptions& options)
    : dimension_(dimension),
      options_(options),
      schedule_(options.schedule, dimension == 2 ? 3 : 6),
      solver_(dimension, options.schedule.shape_c),
      translation_noise_(dimension == 2 ? 2 : 3),
      rotation_noise_(dimension == 2 ? 1 : 3) {
  validate(options_);
  solver_.setTrustRegion(options_.solver.trust_region, options_.solver.trust_region_radius,
                         options_.solver.max_trust_region_radius);
  solver_.setConvergenceStep(options_.solver.convergence_step);
}

void IncrementalGnc::addFirstPose(const Pose& value, const Eigen::MatrixXd& information) {
  if (numPoses() != 0) throw std::invalid_argument("the first pose exists already");
  addPoseWithPrior(value, information);
}

void IncrementalGnc::addPoseWithPrior(const Pose& value, const Eigen::MatrixXd& information) {
  discardIdleChecks();  // they were for the graph before this
  if (!value.translation.allFinite() || !value.rotation.coeffs().allFinite() || !information.allFinite() ||
      value.rotation.norm() < 1e-9)
    throw std::invalid_argument("prior contains NaN, Inf or a zero quaternion");
  const int dim = dimension_ == 2 ? 3 : 6;
  if (information.rows() != dim || information.cols() != dim)
    throw std::invalid_argument("information must be " + std::to_string(dim) + "x" + std::to_string(dim));
  sqrtInformation(information);  // throws if not positive definite
  const int id = solver_.addPose(value);
  solver_.addFactor(SparsePoseGraphSolver::kAnchor, id, value, information, FactorMode::kPlain);
  odometry_into_.push_back(-1);  // the start of a chain
  dead_reckoning_.push_back(value);
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
  discardIdleChecks();  // they were for the graph before this
  validateEdge(edge, /*allow_new_pose=*/true);
  const bool new_pose = edge.to == numPoses();
  if (new_pose) {
    solver_.addPose(solver_.pose(edge.from) * edge.measurement);
    dead_reckoning_.push_back(dead_reckoning_[edge.from] * edge.measurement);
  }
  solver_.addFactor(edge.from, edge.to, edge.measurement, edge.information, FactorMode::kPlain);
  odometry_.push_back(edge);
  if (new_pose) odometry_into_.push_back(edge.from == edge.to - 1 ? static_cast<int>(odometry_.size()) - 1 : -1);
}

int IncrementalGnc::addLoopClosure(const Edge& edge) {
  discardIdleChecks();  // they were for the graph before this
  validateEdge(edge, /*allow_new_pose=*/false);
  LoopClosure loop;
  loop.edge = edge;
  loop.edge.kind = EdgeKind::kLoopClosure;
  loop.factor = solver_.addFactor(edge.from, edge.to, edge.measurement, edge.information, robustMode());
  loops_.push_back(loop);
  const int index = static_cast<int>(loops_.size()) - 1;
  const int newer = newerEnd(edge);
  if (static_cast<int>(loops_by_newer_pose_.size()) <= newer) loops_by_newer_pose_.resize(newer + 1);
  loops_by_newer_pose_[newer].push_back(index);
  pending_.push_back(index);
  sampleNoise(index);
  return index;
}

StepCovariance IncrementalGnc::odometryStep() const {
  return [this](int p) -> Eigen::MatrixXd {
    const int index = odometry_into_[p];
    return index < 0 ? Eigen::MatrixXd() : Eigen::MatrixXd(odometry_[index].information.inverse());
  };
}

void IncrementalGnc::sampleNoise(int index) {
  const int radius = options_.rejection.support_radius;
  if (radius == 0 || options_.schedule.kind == ScheduleKind::kNone) return;
  const Edge& e = loops_[index].edge;
  // The segments between the endpoints as the odometry measured them: the
  // estimate has already bent them towards the loop closures it kept.
  const auto pose = [this](int id) { return dead_reckoning_[id]; };
  const StepCovariance step = odometryStep();
  const int t = dimension_ == 2 ? 2 : 3, r = dimension_ == 2 ? 1 : 3;
  // One sample per loop closure: its most consistent earlier neighbour
  // (noise_scale.h).
  double translation = std::numeric_limits<double>::infinity(), rotation = translation;
  int pairs = 0;
  const int last = std::min(newerEnd(e) + radius, static_cast<int>(loops_by_newer_pose_.size()) - 1);
  for (int p = std::max(0, newerEnd(e) - radius); p <= last; ++p)
    for (int other : loops_by_newer_pose_[p]) {
      Eigen::VectorXd error;
      Eigen::MatrixXd covariance;
      if (other == index || !areNeighbours(e, loops_[other].edge, radius) ||
          !cycleError(dimension_, e, loops_[other].edge, pose, step, &error, &covariance))
        continue;
      // Each block on its own (marginal): a graph may state one too tight
      // and the other right.
      const Eigen::VectorXd et = error.head(t), er = error.tail(r);
      ++pairs;
      translation = std::min(translation, et.dot(covariance.topLeftCorner(t, t).ldlt().solve(et)));
      rotation = std::min(rotation, er.dot(covariance.bottomRightCorner(r, r).ldlt().solve(er)));
    }
  translation_noise_.add(translation, pairs);
  rotation_noise_.add(rotation, pairs);
  if (translation_noise_.samples() < next_noise_estimate_) return;
  while (next_noise_estimate_ <= translation_noise_.samples()) next_noise_estimate_ *= 2;
  // The estimate over every sample so far, lower or higher than the last:
  // the first samples of a run can all be false (Intel with 30 % of its
  // loop closures in local groups begins with 64 poses of them: translation
  // widened 116 times at 64 samples, until the end had the scale stayed).
  const Eigen::VectorXd& now = solver_.noiseScale();
  const double translation_scale = translation_noise_.estimate();
  const double rotation_scale = rotation_noise_.estimate();
  if (translation_scale != now(0) || rotation_scale != now(t)) applyNoiseScale(translation_scale, rotation_scale);
}

void IncrementalGnc::applyNoiseScale(double translation, double rotation) {
  std::vector<char> rejected(loops_.size()), pending(loops_.size(), 0);
  for (size_t index = 0; index < loops_.size(); ++index) rejected[index] = !loops_[index].inlier;
  for (int index : pending_) pending[index] = 1;
  const int t = dimension_ == 2 ? 2 : 3;
  Eigen::VectorXd scale(solver_.noiseScale().size());
  scale.head(t).setConstant(translation);
  scale.tail(scale.size() - t).setConstant(rotation);
  solver_.setNoiseScale(scale);
  // The odds bounds of the paths that ruled loop closures out were of the
  // former noise.
  paths_ruled_out_.clear();
  for (int index = 0; index < static_cast<int>(loops_.size()); ++index) {
    LoopClosure& loop = loops_[index];
    refresh(&loop);
    // Judged again as arrivals: those whose verdict at the estimate as it is
    // the new noise changes (rejected under the former and kept under the
    // new, or the other way round). The others stand.
    const bool verdict_changed = rejected[index] == static_cast<char>(loop.inlier);
    if (!verdict_changed || loop.override_mode != LoopOverride::kAuto || pending[index]) continue;
    loop.uncorroborated = false;
    loop.undone = false;
    loop.landed = false;
    loop.graduation.init_step = 0;
    loop.graduation.mu_init = 0.0;
    pending_.push_back(index);
  }
}

Eigen::MatrixXd IncrementalGnc::widenedInformation(const Eigen::MatrixXd& information) const {
  const Eigen::VectorXd inverse_d = solver_.noiseScale().cwiseSqrt().cwiseInverse();
  return inverse_d.asDiagonal() * information * inverse_d.asDiagonal();
}

Eigen::MatrixXd IncrementalGnc::widenedCovariance(const Eigen::MatrixXd& covariance) const {
  const Eigen::VectorXd d = solver_.noiseScale().cwiseSqrt();
  return d.asDiagonal() * covariance * d.asDiagonal();
}

FactorMode IncrementalGnc::robustMode() const {
  return options_.schedule.kind == ScheduleKind::kNone ? FactorMode::kPlain : FactorMode::kRobust;
}

Poses IncrementalGnc::poses() const {
  Poses out;
  out.reserve(numPoses());
  for (int i = 0; i < numPoses(); ++i) out.push_back(solver_.pose(i));
  return out;
}

double IncrementalGnc::distance(const LoopClosure& loop) const {
  return schedule_.distanceOf(solver_.whitenedNorm(loop.factor));
}

void IncrementalGnc::refresh(LoopClosure* loop) {
  loop->distance = solver_.whitenedNorm(loop->factor);
  switch (loop->override_mode) {
    case LoopOverride::kForceInlier: loop->inlier = true; break;
    case LoopOverride::kForceOutlier: loop->inlier = false; break;
    case LoopOverride::kAuto:
      loop->inlier = schedule_.classifiesAsInlier(loop->distance);
      break;
  }
  // A loop closure the graduation rejected at mu = 1 leaves the cost and
  // the linear system: whatever its Geman-McClure weight there, it does not
  // pull the map. A group of consistent false loop closures 20-50 poses back
  // keeps weights up to 0.017 at mu = 1; ten of them held M3500 0.2 m from
  // its outlier-free optimum. Whether a reset gives it another look is
  // staysDormant's question.
  const bool at_one = decidedAtOne(*loop);
  setDormant(loop, at_one && !schedule_.isInlier(schedule_.distanceOf(loop->distance)));
  // One it kept with a residual its own covariance explains (the chi-square
  // test at q(0.95)) is decided: the estimate is the least-squares one over
  // what the robust objective kept, not Geman-McClure's, whose weight is
  // below 1 for every residual (0.81 at 1 sigma, 0.48 at 2) and so pulls
  // the map towards the odometry wherever noise is heavy. Its cost in the
  // objective stays at mu = 1, so the decisions are judged as before; a
  // restart of its graduation makes it robust again.
  setFullWeight(loop, at_one && schedule_.withinGate(loop->distance));
  loop->weight = solver_.weight(loop->factor);
}

bool IncrementalGnc::decidedAtOne(const LoopClosure& loop) const {
  return loop.override_mode == LoopOverride::kAuto && options_.schedule.kind != ScheduleKind::kNone &&
         !loop.graduation.graduating && loop.graduation.mu >= 1.0;
}

void IncrementalGnc::setDormant(LoopClosure* loop, bool dormant) {
  loop->dormant = dormant;
  solver_.setDormant(loop->factor, dormant);
}

void IncrementalGnc::setFullWeight(LoopClosure* loop, bool full_weight) {
  if (loop->full_weight == full_weight) return;
  loop->full_weight = full_weight;
  solver_.setFullWeight(loop->factor, full_weight);
}

bool IncrementalGnc::staysDormant(const LoopClosure& loop) const {
  if (!loop.dormant) return false;
  // A restart that begins at mu = 1 would graduate it at the weight it has
  // now; if that is still negligible, graduating it changes nothing. One
  // that is not comes back for the restart: its pull, small as it is, is
  // part of how a true loop closure rejected under drift comes back once
  // its neighbours land (leaving it out then folds heavy-noise maps).
  const GraduationState& g = loop.graduation;
  const bool restarts_at_one = options_.schedule.kind == ScheduleKind::kRisam
                                   ? g.mu_init >= 1.0
                                   : g.init_step >= ShapeFunction::kStepsToOne;
  return restarts_at_one && solver_.weight(loop.factor) < options_.rejection.dormant_weight;
}

void IncrementalGnc::classifyAll() {
  for (LoopClosure& loop : loops_) refresh(&loop);
}

void IncrementalGnc::applyOverride(LoopClosure* loop) {
  switch (loop->override_mode) {
    case LoopOverride::kForceInlier: solver_.setMode(loop->factor, FactorMode::kPlain); break;
    case LoopOverride::kForceOutlier: solver_.setMode(loop->factor, FactorMode::kDisabled); break;
    case LoopOverride::kAuto: solver_.setMode(loop->factor, robustMode()); break;
  }
  loop->graduation.graduating = false;
  // Back in the linear system until the next classification says otherwise.
  setDormant(loop, false);
  setFullWeight(loop, false);
}

void IncrementalGnc::setOverride(int index, LoopOverride mode) {
  discardIdleChecks();  // they were for the graph before this
  if (index < 0 || index >= static_cast<int>(loops_.size()))
    throw std::invalid_argument("unknown loop closure " + std::to_string(index));
  loops_[index].override_mode = mode;
  applyOverride(&loops_[index]);
  needs_restart_.push_back(index);
}

void IncrementalGnc::finishAt(LoopClosure* loop, double mu) {
  loop->graduation.mu = mu;
  loop->graduation.graduating = false;
  solver_.setMu(loop->factor, mu);
}

// ---------------------------------------------------------------- update()

UpdateStats IncrementalGnc::update(const std::function<void()>& first_estimate) {
  discardIdleChecks();  // they were for the graph before this
  UpdateStats stats;
  std::function<void()> not_called_yet = first_estimate;
  // A loop closure the map explained tightens the map around its cycle:
  // those rejected there because the map could not tell are judged again,
  // and land in another pass if it now explains them.
  for (bool first = true; !pending_.empty() || !needs_restart_.empty(); first = false) {
    UpdateStats pass;
    std::vector<int> next = updatePass(&pass, &not_called_yet);
    stats = first ? pass : combined(stats, pass);
    pending_ = std::move(next);
  }
  if (stats.iterations > 0) rearmIdleRefinement();
  return stats;
}

std::vector<int> IncrementalGnc::updatePass(UpdateStats* stats, std::function<void()>* first_estimate) {
  // Every pass starts with a small trust region that grows only while the
  // steps agree with the model (see GncOptions::InnerSolver::trust_region_radius).
  solver_.resetTrustRegion();
  // Anytime: judging far loop closures by the map's prediction factorises
  // their cycles, and landing them iterates there: on a large map the
  // slowest work there is. The estimate before it is reported first: the
  // one that stands if they are refused, and within their own noise of
  // what the near loop closures arriving with them would make it.
  UpdatePlan plan = judgeArrivals([&] { reportBeforeFarWork(first_estimate); });
  planWindow(&plan);
  stats->first_variable = plan.first;
  std::vector<int> next;
  bool rolled_back = false;
  if (plan.moves) {
    // Landing a far loop closure is a trial: graduation from the convex
    // start is a heuristic for the robust objective, and a group of false
    // loop closures that agree with each other can lead it to a minimum
    // where the map bends towards them. The trial stands only if it ends
    // lower on the objective than not landing them at all.
    const bool trial = !plan.cycles.empty() && options_.schedule.kind != ScheduleKind::kNone;
    if (trial) reportBeforeFarWork(first_estimate);
    // Judged on the window, which holds the whole cycle of what landed,
    // before the whole-graph refinement spreads the result.
    const Snapshot before = trial ? snapshot(plan.first) : Snapshot();
    selectGraduating(&plan);
    stats->graduated = static_cast<int>(plan.graduating.size());
    const Poses window_before = windowPoses(plan);
    solveWindow(&plan, stats);
    rolled_back = trial && solver_.objective(plan.first) > before.objective;
    if (rolled_back) {
      const std::vector<int> competing = competingLandings(before, plan);
      next = rollBack(before, plan);
      // A group that agrees with itself and that the map refuses is evidence
      // against the map too: an earlier landing it contradicts may be what
      // is wrong. Whatever else was pending is judged in the next pass.
      if (!competing.empty() && releaseAndLand(plan.cycles, competing, stats, first_estimate))
        needs_restart_.clear();
    } else {
      const bool refines = needsRefinement(plan, window_before);
      if (*first_estimate && (refines || !plan.explained.empty())) {
        (*first_estimate)();
        *first_estimate = nullptr;
      }
      if (refines) refine(stats);
    }
  }
  if (!rolled_back) {
    finish(plan, *stats);
    for (int index : plan.cycles) loops_[index].landed = loops_[index].inlier;
    next = explainedAfterLanding(plan.explained);
    needs_restart_.clear();
  }
  total_iterations_ += stats->iterations;
  total_gnc_steps_ += stats->gnc_steps;
  return next;
}

void IncrementalGnc::reportBeforeFarWork(std::function<void()>* first_estimate) const {
  if (!*first_estimate) return;
  (*first_estimate)();
  *first_estimate = nullptr;
}

IncrementalGnc::Snapshot IncrementalGnc::snapshot(int first) const {
  Snapshot s;
  s.first = first;
  s.estimate.reserve(numPoses() - first);
  for (int i = first; i < numPoses(); ++i) s.estimate.push_back(solver_.pose(i));
  s.loops.reserve(loops_.size());
  for (const LoopClosure& l : loops_)
    s.loops.push_back(
        {l.graduation, l.distance, l.weight, l.uncorroborated, l.undone, l.landed, l.inlier, l.dormant,
         l.full_weight});
  s.objective = solver_.objective(first);
  return s;
}

void IncrementalGnc::restoreState(const Snapshot& s) {
  for (int i = s.first; i < numPoses(); ++i) solver_.setPose(i, s.estimate[i - s.first]);
  for (size_t k = 0; k < loops_.size(); ++k) {
    LoopClosure& loop = loops_[k];
    const Snapshot::LoopState& saved = s.loops[k];
    loop.graduation = saved.graduation;
    loop.distance = saved.distance;
    loop.weight = saved.weight;
    loop.uncorroborated = saved.uncorroborated;
    loop.undone = saved.undone;
    loop.landed = saved.landed;
    loop.inlier = saved.inlier;
    solver_.setMu(loop.factor, loop.graduation.mu);
    setDormant(&loop, saved.dormant);
    setFullWeight(&loop, saved.full_weight);
  }
}

std::vector<int> IncrementalGnc::rollBack(const Snapshot& before, const UpdatePlan& plan) {
  restoreState(before);
  // As if the map had not explained them (judgeFar): rejected at mu = 1; a
  // later corroborating loop closure starts another trial with them.
  for (int index : plan.cycles) rejectAsUndone(index);
  std::vector<int> again;
  for (int index : pending_)
    if (std::find(plan.cycles.begin(), plan.cycles.end(), index) == plan.cycles.end()) again.push_back(index);
  return again;
}

void IncrementalGnc::rejectAsUndone(int index) {
  LoopClosure& loop = loops_[index];
  loop.uncorroborated = true;
  loop.undone = true;  // not judged by the map again: no path to keep
  loop.landed = false;
  paths_ruled_out_.erase(index);
  schedule_.startAtOne(&loop.graduation);
  finishAt(&loop, 1.0);
  refresh(&loop);
}

std::vector<int> IncrementalGnc::competingLandings(const Snapshot& before, const UpdatePlan& plan) const {
  // Only a group is evidence enough against the map: a lone far loop
  // closure that the map explained and the objective refused is far more
  // often a random outlier. Which earlier landings the group contradicts,
  // the refused trial cannot tell: its own graduation may have kept a false
  // landing and refused the group instead of pushing the landing out. So
  // every one in the trial's window competes, and the objective judges.
  // Landings older than the window were held fixed: the trial could not
  // move them.
  std::vector<int> competing;
  const bool corroborated = plan.cycles.size() > plan.explained.size();
  if (!corroborated) return competing;
  for (int index = 0; index < static_cast<int>(loops_.size()); ++index) {
    const LoopClosure& loop = loops_[index];
    if (loop.landed && loop.override_mode == LoopOverride::kAuto && before.loops[index].inlier &&
        newerEnd(loop.edge) >= plan.first &&
        std::find(plan.cycles.begin(), plan.cycles.end(), index) == plan.cycles.end())
      competing.push_back(index);
  }
  return competing;
}

bool IncrementalGnc::releaseAndLand(const std::vector<int>& group, const std::vector<int>& released,
                                    UpdateStats* stats, std::function<void()>* first_estimate) {
  // The window frees the cycles of both, so the map can leave the released
  // landings; they stay in the objective, at mu = 1 where the map ends, so
  // the comparison with the estimate before is on the same cost.
  UpdatePlan plan;
  plan.first = numPoses();
  for (int index : group) plan.first = std::min(plan.first, olderEnd(loops_[index].edge));
  for (int index : released) plan.first = std::min(plan.first, olderEnd(loops_[index].edge));
  plan.oldest = plan.first;
  plan.moves = true;
  stats->first_variable = std::min(stats->first_variable, plan.first);
  const Snapshot before = snapshot(plan.first);
  for (int index : released) solver_.setMode(loops_[index].factor, FactorMode::kDisabled);
  for (int index : group) land(index, &plan);
  solver_.resetTrustRegion();
  selectGraduating(&plan);
  const Poses window_before = windowPoses(plan);
  solveWindow(&plan, stats);
  // Released landings the map ends agreeing with stay landed; those it
  // contradicts were the wrong ones.
  for (int index : released) {
    solver_.setMode(loops_[index].factor, robustMode());
    refresh(&loops_[index]);
    if (!loops_[index].inlier) rejectAsUndone(index);
  }
  if (solver_.objective(plan.first) > before.objective) {
    rollBack(before, plan);
    return false;
  }
  const bool refines = needsRefinement(plan, window_before);
  if (*first_estimate && refines) {
    (*first_estimate)();
    *first_estimate = nullptr;
  }
  if (refines) refine(stats);
  finish(plan, *stats);
  for (int index : group) loops_[index].landed = loops_[index].inlier;
  return true;
}

std::vector<int> IncrementalGnc::explainedAfterLanding(const std::vector<int>& landed) {
  std::vector<int> candidates;
  if (landed.empty()) return candidates;
  int low = numPoses(), high = 0;
  for (int index : landed) {
    low = std::min(low, olderEnd(loops_[index].edge));
    high = std::max(high, newerEnd(loops_[index].edge));
  }
  for (int index = 0; index < static_cast<int>(loops_.size()); ++index) {
    const LoopClosure& loop = loops_[index];
    if (loop.uncorroborated && !loop.undone && loop.override_mode == LoopOverride::kAuto && newerEnd(loop.edge) >= low &&
        olderEnd(loop.edge) <= high)
      candidates.push_back(index);
  }
  const std::vector<bool> explained = explainedByTheMap(candidates);
  std::vector<int> out;
  for (size_t i = 0; i < candidates.size(); ++i)
    if (explained[i]) out.push_back(candidates[i]);
  return out;
}

IncrementalGnc::UpdatePlan IncrementalGnc::judgeArrivals(const std::function<void()>& before_prediction) {
  UpdatePlan plan;
  std::vector<int> far;
  for (int index : pending_) {
    LoopClosure& loop = loops_[index];
    if (loop.override_mode != LoopOverride::kAuto || options_.schedule.kind == ScheduleKind::kNone) {
      plan.to_graduate.push_back(index);
      continue;
    }
    schedule_.start(&loop.graduation);
    const double m = distance(loop);
    if (m < schedule_.thresholds().q25) {
      // It already agrees with the estimate: accepted without graduating;
      // the settle iterations take in the little it moves the estimate.
      finishAt(&loop, 1.0);
      plan.decided.push_back(index);
      plan.accepted.push_back(index);
    } else if (m >= schedule_.thresholds().q90) {
      far.push_back(index);
    } else {
      plan.to_graduate.push_back(index);
    }
  }
  if (!far.empty()) judgeFar(far, &plan, before_prediction);
  return plan;
}

void IncrementalGnc::judgeFar(const std::vector<int>& far, UpdatePlan* plan,
                              const std::function<void()>& before_prediction) {
  // A confident outlier by its own covariance. After a long drift a true
  // loop closure is one too, so this alone cannot tell them apart. Two
  // things can: a neighbour that agrees with it (a place seen again yields a
  // run of loop closures that agree with each other; a random outlier
  // rarely has one), or, for a loop closure that comes alone, the map --
  // whether its uncertainty between the endpoints explains the residual
  // better than chance does (loop_prediction.h).
  const auto landed = [plan](int index) {
    return std::find(plan->cycles.begin(), plan->cycles.end(), index) != plan->cycles.end();
  };
  // The pairwise test uses the noise the map shows, as the map's test does
  // (the a-posteriori variance of unit weight over the factors the new loop
  // closures' cycles reach, without them); computed once a pair is tested.
  double variance_factor = 0.0;
  const auto varianceFactor = [this, &variance_factor]() {
    if (variance_factor > 0.0) return variance_factor;
    int oldest = numPoses();
    std::vector<int> judged;
    for (int index : pending_) {
      oldest = std::min(oldest, olderEnd(loops_[index].edge));
      judged.push_back(loops_[index].factor);
    }
    return variance_factor = solver_.varianceFactor(oldest, judged);
  };
  std::vector<int> alone;
  for (int index : far) {
    if (landed(index)) continue;  // as the partner of an earlier one of this update
    const std::vector<int> partners = consistentRun(index, far, varianceFactor);
    if (partners.empty()) {
      alone.push_back(index);
      continue;
    }
    // Land it with the rejected loop closures that agree with it: the
    // whole cycle they close is freed and every GNC step iterates until
    // the correction has landed, so the less convex steps judge them there.
    land(index, plan);
    for (int partner : partners) land(partner, plan);
  }
  // A later one may have landed an earlier one as its partner.
  alone.erase(std::remove_if(alone.begin(), alone.end(), landed), alone.end());
  const std::vector<bool> explained = explainedByTheMap(alone, before_prediction);
  for (size_t i = 0; i < alone.size(); ++i) {
    LoopClosure& loop = loops_[alone[i]];
    if (explained[i]) {
      land(alone[i], plan);
      plan->explained.push_back(alone[i]);
      continue;
    }
    // Pulling the map towards it could only fold it. Rejected at mu = 1,
    // without a solve; a corroborating loop closure arriving later lands
    // it after all (corroboratingLoops).
    loop.uncorroborated = true;
    schedule_.startAtOne(&loop.graduation);
    finishAt(&loop, 1.0);
    plan->decided.push_back(alone[i]);
  }
}

std::vector<bool> IncrementalGnc::explainedByTheMap(const std::vector<int>& loops,
                                                    const std::function<void()>& before_prediction) {
  std::vector<bool> explained(loops.size(), false);
  if (loops.empty()) return explained;
  int first = numPoses();
  std::vector<int> factors;
  for (int index : loops) {
    first = std::min(first, olderEnd(loops_[index].edge));
    factors.push_back(loops_[index].factor);
  }
  // Even prior odds: a far loop closure is as likely false as true until
  // the map says otherwise. A loop closure that even one path of the map
  // between its endpoints cannot explain -- the path alone is less certain
  // than the map -- is decided without factorising the map (a random
  // outlier far off usually is); the others are predicted by the map. The
  // variance factor is the one the map's prediction uses. A loop closure
  // judged again tries first the path that ruled it out last time: a search
  // for the shortest path between far endpoints expands most of the map.
  // Judged again, it must beat odds that grow with its judgements
  // (repeatedJudgementLogOdds): dividing the chance volume by k asks the
  // k-th judgement for a likelihood ratio above k, in both the path's bound
  // and the map's prediction.
  const double variance_factor = solver_.varianceFactor(first, factors);
  const Eigen::VectorXd extent = mapExtent(dimension_, solver_.blocks());
  const bool widened = solver_.noiseScaled();
  std::vector<double> log_volume(loops.size());
  std::vector<int> undecided, undecided_factors;
  std::vector<int> judged_sorted = factors;
  std::sort(judged_sorted.begin(), judged_sorted.end());
  std::unique_ptr<SparsePoseGraphSolver::PathSearch> paths;  // made once a search is needed
  for (size_t i = 0; i < loops.size(); ++i) {
    const int index = loops[i];
    const Edge& e = loops_[index].edge;
    log_volume[i] = logChanceVolume(extent, widened ? widenedInformation(e.information) : e.information) -
                    repeatedJudgementLogOdds(++loops_[index].map_judgements);
    if (stillRuledOut(index, judged_sorted, variance_factor, log_volume[i])) continue;
    if (!paths) paths = std::make_unique<SparsePoseGraphSolver::PathSearch>(solver_.pathSearch(factors));
    std::vector<int> path = rulingOutPath(index, paths.get(), judged_sorted, variance_factor, log_volume[i]);
    if (!path.empty()) {
      paths_ruled_out_[index] = std::move(path);
      continue;
    }
    paths_ruled_out_.erase(index);
    undecided.push_back(static_cast<int>(i));
    undecided_factors.push_back(factors[i]);
  }
  if (undecided.empty()) return explained;
  if (before_prediction) before_prediction();
  // The whole cycle each closes is free; the prediction of the map holds
  // the older poses fixed, which is what landing it would do.
  const std::vector<SparsePoseGraphSolver::Prediction> predictions =
      solver_.predict(undecided_factors, first, factors);
  for (size_t k = 0; k < undecided.size(); ++k) {
    const SparsePoseGraphSolver::Prediction& p = predictions[k];
    explained[undecided[k]] = logPredictionOdds(p.residual, p.covariance, log_volume[undecided[k]]) > 0.0;
  }
  return explained;
}

std::vector<int> IncrementalGnc::rulingOutPath(int index, SparsePoseGraphSolver::PathSearch* paths,
                                               const std::vector<int>& judged_sorted, double variance_factor,
                                               double log_volume) {
  const LoopClosure& loop = loops_[index];
  const int older = olderEnd(loop.edge), newer = newerEnd(loop.edge);
  const auto rulesOut = [&](const std::vector<int>& path) {
    for (int k : path)
      if (std::binary_search(judged_sorted.begin(), judged_sorted.end(), k)) return false;
    const SparsePoseGraphSolver::Prediction along_path = solver_.predictAlongPath(loop.factor, path, variance_factor);
    return logPredictionOddsBound(along_path.residual, along_path.covariance, variance_factor, log_volume) <= 0.0;
  };
  if (path_tree_.root >= 0 && older != path_tree_.root) {
    std::vector<int> path = solver_.pathToRoot(path_tree_, older);
    if (!path.empty()) {
      const std::vector<int> onwards = solver_.findShortestPath(paths, path_tree_.root, newer);
      if (!onwards.empty() || newer == path_tree_.root) {
        path.insert(path.end(), onwards.begin(), onwards.end());
        if (rulesOut(path)) return path;
      }
    }
  }
  std::vector<int> path = solver_.findShortestPath(paths, older, newer);
  if (!rulesOut(path)) return {};
  path_tree_ = solver_.pathTree(paths, newer);
  return path;
}

bool IncrementalGnc::stillRuledOut(int index, const std::vector<int>& judged_sorted, double variance_factor,
                                   double log_volume) const {
  const auto found = paths_ruled_out_.find(index);
  if (found == paths_ruled_out_.end()) return false;
  const std::vector<int>& path = found->second;
  for (int k : path)
    if (std::binary_search(judged_sorted.begin(), judged_sorted.end(), k)) return false;
  // Infinite where a factor of the path left the map (dormant, disabled).
  const SparsePoseGraphSolver::Prediction along_path =
      solver_.predictAlongPath(loops_[index].factor, path, variance_factor);
  return logPredictionOddsBound(along_path.residual, along_path.covariance, variance_factor, log_volume) <= 0.0;
}

void IncrementalGnc::land(int index, UpdatePlan* plan) {
  paths_ruled_out_.erase(index);
  LoopClosure& loop = loops_[index];
  loop.uncorroborated = false;
  loop.undone = false;
  loop.graduation.init_step = 0;
  loop.graduation.mu_init = 0.0;
  setDormant(&loop, false);
  plan->to_graduate.push_back(index);
  plan->cycles.push_back(index);
}

std::vector<int> IncrementalGnc::corroboratingLoops(int index, const std::vector<int>& far,
                                                    const std::function<double()>& variance_factor) const {
  // Rejected loop closures, or far ones arriving in the same update, whose
  // endpoints both lie within support_radius poses of this one's and that
  // pass PCM's pairwise consistency test with it: a place seen again
  // produces a run of such loop closures, an outlier rarely has a
  // consistent neighbour.
  std::vector<int> partners;
  const int radius = options_.rejection.support_radius;
  if (radius == 0) return partners;
  const Edge& e = loops_[index].edge;
  const int last = std::min(newerEnd(e) + radius, static_cast<int>(loops_by_newer_pose_.size()) - 1);
  for (int p = std::max(0, newerEnd(e) - radius); p <= last; ++p) {
    for (int other : loops_by_newer_pose_[p]) {
      const LoopClosure& candidate = loops_[other];
      // Rejected by the graduation's own test, whatever the user sees, or
      // as a far loop closure the map ruled out or whose trial the
      // objective refused (uncorroborated): the test alone misses those
      // left between the far gate and the inlier gate, q(0.90) <= d <
      // q(0.95), where a far arrival can stay.
      const bool rejected = (candidate.uncorroborated ||
                             !schedule_.isInlier(schedule_.distanceOf(candidate.distance))) &&
                            !candidate.graduation.graduating;
      const bool arriving = std::find(far.begin(), far.end(), other) != far.end();
      if (other == index || candidate.override_mode != LoopOverride::kAuto || !(rejected || arriving) ||
          !areNeighbours(e, candidate.edge, radius))
        continue;
      if (pairAgrees(e, candidate.edge, variance_factor())) partners.push_back(other);
    }
  }
  return partners;
}

bool IncrementalGnc::pairAgrees(const Edge& a, const Edge& b, double variance_factor) const {
  const auto pose = [this](int id) { return solver_.pose(id); };
  const StepCovariance step = odometryStep();
  double d;
  if (solver_.noiseScaled()) {
    // Under the noise scale (noiseScale()), every covariance of the cycle widened.
    const auto widenedEdge = [this](Edge edge) {
      edge.information = widenedInformation(edge.information);
      return edge;
    };
    const StepCovariance widened_step = [this, &step](int p) -> Eigen::MatrixXd {
      const Eigen::MatrixXd stated = step(p);
      return stated.size() == 0 ? stated : widenedCovariance(stated);
    };
    d = cycleDistance(dimension_, widenedEdge(a), widenedEdge(b), pose, widened_step, variance_factor);
  } else {
    d = cycleDistance(dimension_, a, b, pose, step, variance_factor);
  }
  return d * d < schedule_.thresholds().q95;
}

std::vector<int> IncrementalGnc::consistentRun(int index, const std::vector<int>& far,
                                               const std::function<double()>& variance_factor) const {
  // A revisit is judged whole: the partners of partners belong to the same
  // run of the place seen again, and each one that was refused alone (or in
  // a smaller part of the run) is evidence for the others.
  std::vector<int> run;
  std::vector<int> frontier{index};
  while (!frontier.empty()) {
    const int member = frontier.back();
    frontier.pop_back();
    for (int partner : corroboratingLoops(member, far, variance_factor)) {
      if (partner == index || std::find(run.begin(), run.end(), partner) != run.end()) continue;
      run.push_back(partner);
      frontier.push_back(partner);
    }
  }
  return run;
}

void IncrementalGnc::planWindow(UpdatePlan* plan) const {
  // The free poses: from the oldest endpoint of what changes on, but
  // reaching at most max_window_poses back from a loop closure's newer
  // endpoint -- except for a loop closure that needs its whole cycle to land
  // (judgeArrivals), which frees everything from its older endpoint on.
  plan->oldest = numPoses();
  plan->first = numPoses();
  auto reach = [&](const Edge& e, bool whole_cycle) {
    plan->oldest = std::min(plan->oldest, olderEnd(e));
    const bool bounded = options_.window.max_poses > 0 && !whole_cycle;
    plan->first = std::min(plan->first, bounded ? std::max(olderEnd(e), newerEnd(e) + 1 - options_.window.max_poses)
                                                : olderEnd(e));
  };
  for (int index : plan->to_graduate)
    reach(loops_[index].edge,
          std::find(plan->cycles.begin(), plan->cycles.end(), index) != plan->cycles.end());
  for (int index : plan->accepted) reach(loops_[index].edge, false);
  for (int index : needs_restart_) reach(loops_[index].edge, false);
  if (!options_.window.local) plan->first = 0;
  plan->moves = !plan->to_graduate.empty() || !needs_restart_.empty() || !plan->accepted.empty();
}

void IncrementalGnc::selectGraduating(UpdatePlan* plan) {
  std::vector<char> selected(loops_.size(), 0);
  for (int index : plan->decided) selected[index] = 1;
  auto select = [&](int index) {
    LoopClosure& loop = loops_[index];
    if (selected[index] || loop.override_mode != LoopOverride::kAuto) return;
    selected[index] = 1;
    if (staysDormant(loop)) {
      plan->still_dormant.push_back(index);
      return;
    }
    setDormant(&loop, false);
    setFullWeight(&loop, false);
    schedule_.start(&loop.graduation);
    if (loop.graduation.graduating) plan->graduating.push_back(index);
  };
  for (int index : plan->to_graduate) select(index);
  for (int index : needs_restart_) select(index);
  // Older decisions are revisited only where the estimate may move much: if
  // every new loop closure already agreed with it, they stand.
  const bool reset = options_.schedule.reset != ResetPolicy::kNone && (!plan->to_graduate.empty() || !needs_restart_.empty());
  // A loop closure with both ends held fixed cannot move in this update.
  const int reach = std::max(plan->oldest, plan->first);
  if (reset) {
    // In index order, as the loop closures arrived, found through the poses
    // that can move: a window costs what it holds, not the map.
    std::vector<int> in_reach;
    if (options_.schedule.reset == ResetPolicy::kAll) {
      in_reach.resize(loops_.size());
      std::iota(in_reach.begin(), in_reach.end(), 0);
    } else {
      for (int pose = std::max(reach, 0); pose < static_cast<int>(loops_by_newer_pose_.size()); ++pose)
        in_reach.insert(in_reach.end(), loops_by_newer_pose_[pose].begin(), loops_by_newer_pose_[pose].end());
      std::sort(in_reach.begin(), in_reach.end());
    }
    for (int index : in_reach) select(index);
  }
  plan->graduated = plan->graduating;
}

Poses IncrementalGnc::windowPoses(const UpdatePlan& plan) const {
  Poses window;
  if (!mayRefine(plan)) return window;
  window.reserve(numPoses() - plan.first);
  for (int i = plan.first; i < numPoses(); ++i) window.push_back(solver_.pose(i));
  return window;
}

bool IncrementalGnc::mayRefine(const UpdatePlan& plan) const {
  return plan.first > 0 && options_.window.global_refinement;
}

void IncrementalGnc::solveWindow(UpdatePlan* plan, UpdateStats* stats) {
  // Landing a far loop closure frees its whole cycle so that the correction
  // lands: there the trust region only has to keep the model honest, and a
  // step the model predicts well goes as far as it keeps doing so
  // (SparsePoseGraphSolver::setStepExtension). In a bounded window the
  // radius also keeps a new outlier at a small mu from pulling the map far.
  solver_.setStepExtension(!plan->cycles.empty());
  runGncSteps(plan, stats);
  settle(plan->first, maxSettleIterations(), plan->last_step, stats);
  solver_.setStepExtension(false);
}

void IncrementalGnc::runGncSteps(UpdatePlan* plan, UpdateStats* stats) {
  // Every step sets mu of each graduating loop closure from its schedule,
  // then iterates while the steps are large: a large correction must land
  // before the next, less convex, step judges it.
  std::vector<int>& graduating = plan->graduating;
  while (!graduating.empty() && stats->gnc_steps < options_.schedule.max_gnc_steps) {
    for (int index : graduating) {
      LoopClosure& loop = loops_[index];
      schedule_.advance(&loop.graduation, distance(loop));
      solver_.setMu(loop.factor, loop.graduation.mu);
    }
    IterationResult r = iterateOnce(plan->first, stats);
    for (int extra = 1; extra < options_.solver.max_iterations_per_step && r.accepted &&
                        convergenceStep(r) >= options_.solver.convergence_step;
         ++extra)
      r = iterateOnce(plan->first, stats);
    ++stats->gnc_steps;
    if (r.accepted) plan->last_step = convergenceStep(r);
    for (int index : graduating) schedule_.finishStep(&loops_[index].graduation);
    if (r.accepted && convergenceStep(r) < options_.solver.convergence_step) acceptConsistent(graduating);
    graduating.erase(std::remove_if(graduating.begin(), graduating.end(),
                                    [this](int i) { return !loops_[i].graduation.graduating; }),
                     graduating.end());
  }
}

void IncrementalGnc::acceptConsistent(const std::vector<int>& graduating) {
  // The estimate has settled: a graduating loop closure that is a confident
  // inlier there keeps its weight whatever mu it reaches, so the remaining
  // steps would not move it.
  for (int index : graduating) {
    LoopClosure& loop = loops_[index];
    if (loop.graduation.graduating && distance(loop) < schedule_.thresholds().q25) finishAt(&loop, 1.0);
  }
}

int IncrementalGnc::maxSettleIterations() const {
  return options_.schedule.kind == ScheduleKind::kNone
             ? std::max(options_.solver.max_settle_iterations, kMinPlainIterations)
             : options_.solver.max_settle_iterations;
}

bool IncrementalGnc::needsRefinement(const UpdatePlan& plan, const Poses& window_before) {
  // The window held older poses fixed. If the update moved the estimate, let
  // the whole graph follow (the correction belongs to every pose, not only to
  // those in the window). "Moved" is judged as a whole-graph solve would be --
  // the mean displacement over all poses -- and small corrections add up
  // across updates: the refinement runs once those since the last one amount
  // to convergence_step, so a window that shifted a little does not cost
  // whole-graph iterations every time. The displacement is net: an outlier
  // that pulled the window at a small mu and was then rejected moved it
  // there and back, which calls for no refinement.
  if (plan.first == 0) unrefined_step_ = 0.0;
  if (!mayRefine(plan)) return false;
  for (int i = plan.first; i < numPoses(); ++i)
    unrefined_step_ += displacement(window_before[i - plan.first], solver_.pose(i));
  return unrefined_step_ / numPoses() >= options_.solver.convergence_step;
}

void IncrementalGnc::refine(UpdateStats* stats) {
  const int before = stats->iterations;
  settleWholeGraph(maxSettleIterations(), stats);
  stats->refinement_iterations = stats->iterations - before;
  unrefined_step_ = 0.0;
}

void IncrementalGnc::finish(const UpdatePlan& plan, const UpdateStats& stats) {
  // Decided and graduated loop closures adapt where their next graduation
  // starts (if the estimate converged) and are classified.
  auto adapt = [&](int index) {
    LoopClosure& loop = loops_[index];
    refresh(&loop);
    if (stats.converged) schedule_.adaptInitial(&loop.graduation, schedule_.distanceOf(loop.distance));
  };
  for (int index : plan.decided) adapt(index);
  for (int index : plan.graduated) adapt(index);
  // Skipped as dormant: did the estimate move towards one of them?
  for (int index : plan.still_dormant) refresh(&loops_[index]);
  // Not graduating but changed: schedule none, or an override.
  for (int index : pending_) refresh(&loops_[index]);
  for (int index : needs_restart_) refresh(&loops_[index]);
}

IterationResult IncrementalGnc::iterateOnce(int first, UpdateStats* stats) {
  const IterationResult r = solver_.iterate(first);
  ++stats->iterations;
  return r;
}

void IncrementalGnc::settle(int first, int max_iterations, double last_step, UpdateStats* stats) {
  int done = 0;
  while (done < max_iterations && last_step >= options_.solver.convergence_step) {
    const IterationResult r = iterateOnce(first, stats);
    ++done;
    if (!r.accepted) break;  // nothing reduces the cost: converged as far as we can go
    last_step = convergenceStep(r);
  }
  stats->converged = last_step < options_.solver.convergence_step;
}

void IncrementalGnc::settleWholeGraph(int max_iterations, UpdateStats* stats) {
  // No loop closure is graduating: nothing left for the radius to hold back.
  solver_.setStepExtension(true);
  settle(0, max_iterations, std::numeric_limits<double>::infinity(), stats);
  solver_.setStepExtension(false);
}

UpdateStats IncrementalGnc::optimize(int max_iterations) {
  discardIdleChecks();  // they were for the graph before this
  UpdateStats stats;
  solver_.resetTrustRegion();
  settleWholeGraph(max_iterations, &stats);
  classifyAll();
  if (stats.converged) idle_converged_ = true;
  total_iterations_ += stats.iterations;
  return stats;
}

void IncrementalGnc::rearmIdleRefinement() {
  idle_converged_ = false;
  idle_iterations_ = 0;
  fold_check_due_ = options_.schedule.kind != ScheduleKind::kNone;
  full_weight_check_due_ = fold_check_due_;
}

bool IncrementalGnc::idleCheckIteration(int* stage_iterations) {
  UpdateStats stats;
  solver_.setStepExtension(true);
  const IterationResult r = iterateOnce(0, &stats);
  solver_.setStepExtension(false);
  total_iterations_ += stats.iterations;
  const bool converged = !r.accepted || convergenceStep(r) < options_.solver.convergence_step ||
                         ++*stage_iterations >= kMaxIdleIterations;
  if (converged) *stage_iterations = 0;
  return converged;
}

bool IncrementalGnc::refineIdle() {
  if (!hasIdleWork()) return false;
  if (idle_converged_) {
    if (fold_check_due_)
      stepFoldCheck();
    else
      stepFullWeightCheck();
    return true;
  }
  // The first iteration of an idle period starts the trust region afresh,
  // as an update does; later ones keep the radius the steps earned.
  if (idle_iterations_ == 0) solver_.resetTrustRegion();
  UpdateStats stats;
  solver_.setStepExtension(true);
  const IterationResult r = iterateOnce(0, &stats);
  solver_.setStepExtension(false);
  ++idle_iterations_;
  total_iterations_ += stats.iterations;
  if (!r.accepted || convergenceStep(r) < options_.solver.convergence_step || idle_iterations_ >= kMaxIdleIterations) {
    idle_converged_ = true;
    unrefined_step_ = 0.0;
    classifyAll();
  }
  return true;
}

}  // namespace core
}  // namespace agnc_pgo
