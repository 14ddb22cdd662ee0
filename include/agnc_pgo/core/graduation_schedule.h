// Graduation of one loop closure: how its mu rises step by step, when it
// stops, how its starting point adapts after convergence, and how it is
// finally classified (ALGORITHM.md §3-4). Pure functions of a small state, so
// each rule is tested on its own (as GTSAM's GncOptimizer splits its steps).
#pragma once

#include "agnc_pgo/core/chi_square.h"
#include "agnc_pgo/core/gnc_options.h"

namespace agnc_pgo {
namespace core {

// The graduation state of one loop closure.
struct GraduationState {
  double mu = 0.0;        // the kernel's current mu
  int step = 0;           // next GNC step index (AGNC: position on the curve)
  int init_step = 0;      // AGNC: step a (re)start begins at (0 or 3)
  double mu_init = 0.0;   // riSAM: mu a (re)start begins at
  double alpha = 0.0;     // AGNC: interpolation parameter used at the last step
  int steps_at_one = 0;   // solves done with mu == 1 in this graduation
  bool graduating = false;
};

class GraduationSchedule {
 public:
  GraduationSchedule(const GncOptions::Schedule& options, int dof);

  // (Re)starts graduation: the next step is the first one.
  void start(GraduationState* state) const;

  // Sets mu for the coming solve from the factor's current distance
  // (`distance` under the configured convention) and advances the step.
  void advance(GraduationState* state, double distance) const;

  // Called after the solve: a factor leaves graduation on the step after it
  // reached mu = 1 (so a new loop closure costs 5 AGNC / 6 riSAM solves).
  void finishStep(GraduationState* state) const;

  // Makes every later (re)start begin at mu = 1 (a confident outlier).
  void startAtOne(GraduationState* state) const;

  // After convergence: riSAM raises/lowers mu_init, AGNC sets init_step to
  // 3 (confident outlier) or 0 (confident inlier).
  void adaptInitial(GraduationState* state, double distance) const;

  // alpha of the paper's adaptive rule (0 below q(0.25), 1 at or above q(0.9)).
  double adaptiveAlpha(double distance) const;
  // alpha of the reference code's rule, expressed on the same scale
  // (0 = gradual curve): jumps at both band edges.
  double referenceAlpha(double distance) const;

  // The graduation's own test: `distance` (under the convention) < q(0.95).
  // The engine uses it to tell rejected loop closures from kept ones.
  bool isInlier(double distance) const { return distance < thresholds_.q95; }

  // The chi-square test of a whitened residual norm r under the stated
  // covariance, whatever the convention: r^2 < q(0.95).
  bool withinGate(double r) const { return r * r < thresholds_.q95; }

  // The classification a user sees for a whitened residual norm r
  // (GncOptions::Schedule::classification), and the value it compares with
  // q(0.95): r^2 for kWeight, the convention's distance for kDistance.
  bool classifiesAsInlier(double r) const { return classificationDistance(r) < thresholds_.q95; }
  double classificationDistance(double r) const;

  // The value compared with the quantiles for a whitened residual norm r.
  double distanceOf(double r) const;

  const ChiSquareThresholds& thresholds() const { return thresholds_; }
  const GncOptions::Schedule& options() const { return options_; }

  // riSAM's ladder: min(1, 2.2 mu + 0.12).
  static double nextRisamMu(double mu);

 private:
  GncOptions::Schedule options_;
  int dof_;
  ChiSquareThresholds thresholds_;
};

}  // namespace core
}  // namespace agnc_pgo
