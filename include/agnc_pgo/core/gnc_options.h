// Options of the incremental GNC engine: a plain struct, built and validated
// outside the algorithm (command line, ROS parameters, tests).
#pragma once

#include <string>
#include <vector>

namespace agnc_pgo {
namespace core {

// How mu rises for a graduating loop closure (ALGORITHM.md §3).
enum class ScheduleKind {
  kNone,       // plain least squares on every loop closure, no GNC
  kRisam,      // mu <- min(1, 2.2 mu + 0.12)
  kAgncFixed,  // B-spline shape function with a fixed alpha (paper's "mode 1")
  kAgnc,       // B-spline shape function with the adaptive alpha (paper's "mode 2")
};

// What the chi-square quantiles are compared with.
enum class DistanceConvention {
  kReference,  // the whitened residual norm r (both reference implementations)
  kSquared,    // r^2, the statistically standard test
};

// Which existing loop closures restart graduation when new ones arrive.
enum class ResetPolicy {
  kNone,    // only the new loop closures graduate
  kWindow,  // also every loop closure with an endpoint at or after the oldest
            // endpoint of a new one (a batch stand-in for riSAM's Bayes-tree)
  kAll,     // every loop closure
};

struct GncOptions {
  ScheduleKind schedule = ScheduleKind::kAgnc;
  DistanceConvention distance = DistanceConvention::kReference;
  ResetPolicy reset = ResetPolicy::kWindow;
  double shape_c = 3.0;        // SIG kernel shape (inliers within ~c sigma)
  double fixed_alpha = 0.5;    // kAgncFixed
  // kAgnc: interpolate as the AGNC reference code does ((cdf(m) - 0.25) / 0.65,
  // with alpha = 0 meaning the rapid curve inside the band) instead of the paper.
  bool reference_alpha_direction = false;
  // After graduation, Gauss-Newton iterations continue until the mean tangent
  // step per pose falls below `convergence_step` or `max_settle_iterations`.
  int max_settle_iterations = 3;
  double convergence_step = 0.01;
  // mu_init / init_step adaptation of the loop closures that graduated.
  bool adapt_initial_mu = true;
  // Free only the poses from the oldest endpoint of the new loop closures on
  // (older poses held fixed) instead of the whole graph.
  bool local_window = true;
  // With local_window: free at most the newest max_window_poses poses (0: no
  // bound). A loop closure to a pose older than that corrects the recent
  // trajectory against the old map, held fixed; the whole-graph refinement
  // below then spreads the correction. Bounds the cost of an update however
  // far back a loop closure reaches.
  int max_window_poses = 200;
  // With local_window: after an update that moved the estimate, iterate on
  // the whole graph until it settles too.
  bool global_refinement = true;
  // Shortcut: once a GNC step barely moved the estimate (mean step below
  // convergence_step), graduating loop closures that are confident inliers
  // (distance < q(0.25)) jump to mu = 1 and stop graduating: their kernel
  // weight hardly depends on mu, so the remaining steps would not move them.
  bool early_accept_consistent = true;
  // Shortcut before the first step: a new loop closure that already agrees
  // with the estimate (distance < q(0.25)) starts at mu = 1 and does not
  // graduate; if every new one agrees, the reset policy is skipped too (the
  // estimate will barely move, so older decisions stand).
  bool accept_consistent_on_arrival = true;
  // Gauss-Newton iterations per GNC step at most (more only while the mean
  // step per pose is at least convergence_step). 1 = one warm-started
  // iteration per step, as riSAM's one iSAM2 update per step.
  int iterations_per_step = 1;
  // Dogleg trust region for every iteration (riSAM runs iSAM2 with Dogleg),
  // starting at trust_region_radius and never growing past
  // max_trust_region_radius (tangent-space norm of the whole step).
  bool trust_region = true;
  double trust_region_radius = 1.0;
  double max_trust_region_radius = 1e3;
  // Restart the radius at trust_region_radius at every update instead of
  // carrying it over. A radius left large by earlier updates lets the first
  // (mu = 0, nearly quadratic) step of a new outlier fold the map before
  // graduation can reject it (first 1200 poses of M3500 at 30 %: ATE 10.7 m
  // carried over, 0.76 m restarted); restarted, the radius triples with every
  // step the model predicts well, so a large legitimate correction (a batch
  // of ring-closing loop closures) still lands within a few steps.
  bool restart_trust_region = true;
  // A rejected loop closure whose kernel weight at mu = 1 is below this
  // leaves the cost and the linear system until a reset would give it weight
  // again (0: never). Keeping random false loop closures costs fill-in (on
  // M3500 they made full solves ~6x slower) and accuracy: their Geman-McClure
  // tails pull the map (M3500 at 50 %: ATE 0.934 m kept down to 1e-8, 0.810 m
  // from 1e-6, against 0.795 m without outliers).
  double dormant_weight = 1e-6;
  // The same threshold for a rejected loop closure that agrees with a
  // neighbouring one (see support_radius). Such a pair is what true loop
  // closures look like when the drift is not yet corrected: the Vertigo ring
  // closes only through the pull of its 26 rejected closing loop closures
  // (recall 1.0 kept down to 1e-8, 0 dropped at 1e-6).
  double supported_dormant_weight = 1e-8;
  // A loop closure is supported when another one whose endpoints both lie
  // within this many poses of its own passes the pairwise consistency test
  // (loop_consistency.h) at q(0.95). 0: none is supported.
  int support_radius = 5;
  // A rejected loop closure whose weight at mu = 1 is below this (but above
  // its dormant threshold: with the defaults, a supported one between 1e-8
  // and 1e-6) stays in the cost and the gradient -- its pull is kept --
  // but not in the Hessian's off-diagonal blocks, so it adds no fill-in
  // (see SparsePoseGraphSolver::setDecoupled). 0: never. 1e-6, not larger:
  // at 1e-4 (or 1e-5) the agnc schedule lost true loop closures on the
  // 20 000-pose synthetic grid (recall 0.94 against 0.999), whose drifted
  // loop closures recover through that pull; at 1e-6 M3500 at 50 % still
  // runs about 5x faster than without decoupling.
  double decoupled_weight = 1e-6;
  // Safety bound on GNC steps per update (a loop closure needs at most 6).
  int max_gnc_steps = 30;
};

// Parsing for command lines and parameter servers; throw std::invalid_argument
// naming the accepted values.
ScheduleKind parseSchedule(const std::string& name);
DistanceConvention parseDistanceConvention(const std::string& name);
ResetPolicy parseResetPolicy(const std::string& name);
std::string toString(ScheduleKind kind);
std::string toString(DistanceConvention convention);
std::string toString(ResetPolicy policy);

// Throws std::invalid_argument with the offending field if out of range.
void validate(const GncOptions& options);

}  // namespace core
}  // namespace agnc_pgo
