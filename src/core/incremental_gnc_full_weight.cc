// IncrementalGnc's full-weight check (incremental_gnc.h, FullWeightCheck):
// in idle time, the kept loop closures left on Geman-McClure's weights
// beyond the chi-square gate are tried at full weight.
//
// Why. A loop closure the graduation keeps counts at full weight where its
// residual is within the chi-square gate (refresh()), so that the estimate
// is least squares over what the robust objective kept. The gate is judged
// at the current estimate, and on a long-drift map two states answer it
// consistently: least squares, where such a loop closure sits within its
// gate, and Geman-McClure's weights, whose pull below 1 (0.48 at 2 sigma)
// lets the odometry draw it beyond the gate, where its weight falls further
// (0.25 at 3 sigma). Which one the updates leave follows their path: with
// every decision right, kitti_00 ended 0.014 m from its least-squares
// optimum and generated long-drift worlds 0.08-0.23 m, each with a few
// true loop closures at 3-7 sigma that least squares puts within 2.
// The check asks the gate's question at the estimate the rule is meant
// for. Stages, one whole-graph iteration per refineIdle() call:
//   start        the candidates -- kept, decided at mu = 1, not at full
//                weight -- at full weight;
//   converge     the whole graph; then those still beyond the gate go back
//                to their kernel weight and it converges again, until none
//                does (each round returns one at least);
//   verdict      the result stands if every loop closure at full weight
//                before the check is still within its gate and every
//                candidate is still kept: what the check adds agrees with
//                what was already trusted. Otherwise the engine's state
//                stays, as it was.
// Between calls the engine's own state is back in place (restoreState), as
// in the fold check.
#include <memory>
#include <vector>

#include "agnc_pgo/core/incremental_gnc.h"

namespace agnc_pgo {
namespace core {

bool IncrementalGnc::startFullWeightCheck() {
  auto check = std::make_unique<FullWeightCheck>();
  for (int k = 0; k < static_cast<int>(loops_.size()); ++k) {
    const LoopClosure& loop = loops_[k];
    if (loop.dormant || !decidedAtOne(loop)) continue;
    if (loop.full_weight)
      check->trusted.push_back(k);
    else if (loop.inlier)
      check->candidates.push_back(k);
  }
  if (check->candidates.empty()) return false;
  for (int k : check->candidates) setFullWeight(&loops_[k], true);
  solver_.resetTrustRegion();
  full_weight_check_ = std::move(check);
  return true;
}

bool IncrementalGnc::demoteBeyondTheGate(const std::vector<int>& candidates) {
  bool demoted = false;
  for (int k : candidates) {
    LoopClosure& loop = loops_[k];
    if (!loop.full_weight || schedule_.withinGate(solver_.whitenedNorm(loop.factor))) continue;
    setFullWeight(&loop, false);
    demoted = true;
  }
  return demoted;
}

bool IncrementalGnc::fullWeightStands(const FullWeightCheck& check) const {
  for (int k : check.trusted)
    if (!schedule_.withinGate(solver_.whitenedNorm(loops_[k].factor))) return false;
  for (int k : check.candidates)
    if (!schedule_.isInlier(distance(loops_[k]))) return false;
  return true;
}

void IncrementalGnc::stepFullWeightCheck() {
  const Snapshot own = snapshot(0);
  if (!full_weight_check_) {
    if (!startFullWeightCheck()) {
      full_weight_check_due_ = false;
      return;
    }
  } else {
    restoreState(full_weight_check_->alternative);
    FullWeightCheck& check = *full_weight_check_;
    if (idleCheckIteration(&check.iterations)) {
      if (!demoteBeyondTheGate(check.candidates)) {
        full_weight_check_due_ = false;
        const bool stands = fullWeightStands(check);
        full_weight_check_.reset();
        if (stands)
          classifyAll();
        else
          restoreState(own);
        return;
      }
    }
  }
  full_weight_check_->alternative = snapshot(0);
  restoreState(own);
}

}  // namespace core
}  // namespace agnc_pgo
