// Options of the incremental GNC engine: a plain struct, grouped by concern,
// built and validated outside the algorithm (command line, ROS parameters,
// tests).
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

// What decides the classification a user sees (inlier / outlier).
enum class Classification {
  // The kernel's verdict: inlier iff r^2 < q(0.95), i.e. iff the loop
  // closure's weight at mu = 1 is at least that of a residual at the
  // chi-square gate (0.287 in 2-D, 0.174 in 3-D for c = 3). A loop closure
  // reported as an inlier pulls the map; one reported as an outlier hardly
  // does.
  kWeight,
  // The graduation's distance convention against q(0.95) (with `reference`:
  // r < q(0.95), as both reference implementations classify; a loop closure
  // 10 sigma off in 3-D is then an inlier at weight 0.007).
  kDistance,
};

// Which existing loop closures restart graduation when new ones arrive.
enum class ResetPolicy {
  kNone,    // only the new loop closures graduate
  kWindow,  // also every loop closure with an endpoint at or after the oldest
            // endpoint of a new one (a batch stand-in for riSAM's Bayes-tree)
  kAll,     // every loop closure
};

struct GncOptions {
  // The SIG kernel and how its mu rises, step by step (graduation_schedule.h).
  struct Schedule {
    ScheduleKind kind = ScheduleKind::kAgnc;
    // The convention of the graduation: the alpha rule, the arrival bands
    // and the adaptation of the starting point (the paper's is `reference`).
    DistanceConvention distance = DistanceConvention::kReference;
    // The report keeps the reference code's classification by default:
    // kWeight costs recall on true loop closures the kernel down-weights
    // (README, "Classification").
    Classification classification = Classification::kDistance;
    ResetPolicy reset = ResetPolicy::kWindow;
    double shape_c = 3.0;        // SIG kernel shape (inliers within ~c sigma)
    double fixed_alpha = 0.5;    // kAgncFixed
    // kAgnc: interpolate as the AGNC reference code does ((cdf(m) - 0.25) / 0.65,
    // with alpha = 0 meaning the rapid curve inside the band) instead of the paper.
    bool reference_alpha_direction = false;
    // mu_init / init_step adaptation of the loop closures that graduated.
    bool adapt_initial_mu = true;
    // Safety bound on GNC steps per update (a loop closure needs at most 6).
    int max_gnc_steps = 30;
  };

  // The inner solver: the Gauss-Newton / dogleg iterations of each GNC step
  // (sparse_pose_graph_solver.h).
  struct InnerSolver {
    // Iterations per GNC step at most: a step iterates while its mean step
    // per pose is at least convergence_step, so a large correction lands
    // before the next, less convex, step judges it, while a step that
    // changes little costs one iteration (riSAM: one iSAM2 update per step).
    int max_iterations_per_step = 10;
    // After graduation, iterations continue until the mean tangent step per
    // pose falls below `convergence_step` or `max_settle_iterations`. The
    // step judged is the next one as far as this one predicts it: after a
    // full Gauss-Newton step, its linear solve's residual plus 3/2 |1 - rho|
    // of it (rho: actual over predicted decrease), never more than itself.
    int max_settle_iterations = 3;
    double convergence_step = 0.01;
    // Powell dogleg trust region for every iteration (riSAM runs iSAM2 with
    // Dogleg), restarted at trust_region_radius by every update and growing
    // with each step the quadratic model predicts well, never past
    // max_trust_region_radius (tangent-space norm of the whole step).
    bool trust_region = true;
    double trust_region_radius = 1.0;
    double max_trust_region_radius = 1e3;
  };

  // Which poses are free in an update.
  struct Window {
    // Free only the poses from the oldest endpoint of the new loop closures
    // on (older poses held fixed) instead of the whole graph.
    bool local = true;
    // With local: free at most the newest max_poses poses (0: no bound). A
    // loop closure to a pose older than that corrects the recent trajectory
    // against the old map, held fixed; the whole-graph refinement below then
    // spreads the correction. Bounds the cost of an update however far back
    // a loop closure reaches (a far loop closure that lands frees its whole
    // cycle, see Rejection::support_radius).
    int max_poses = 200;
    // With local: after an update that moved the estimate, iterate on the
    // whole graph until it settles too.
    bool global_refinement = true;
  };

  // Loop closures rejected on arrival or by graduation.
  struct Rejection {
    // A loop closure the graduation rejected at mu = 1 leaves the cost and
    // the linear system (dormant): its Geman-McClure tail would pull the map
    // (a rejected group of local false loop closures keeps weights up to
    // 0.017) and its fill-in slow every solve. A reset (ResetPolicy) brings
    // it back for another look unless its weight at mu = 1 is below this:
    // then graduating it again would change nothing (0: a reset always
    // brings it back).
    double dormant_weight = 1e-6;
    // A new loop closure that is a confident outlier by its own covariance
    // (beyond q(0.9)) is landed -- its whole cycle freed -- when a rejected
    // loop closure whose endpoints both lie within this many poses of its own
    // passes the pairwise consistency test with it (loop_consistency.h, at
    // q(0.95)): a place seen again after a long drift yields a run of such
    // loop closures, and the run lands as one trial (the neighbours of its
    // neighbours, transitively). Otherwise it is landed if the map explains
    // it better than chance (loop_prediction.h), and rejected without a
    // solve if not.
    // Either way the landing is a trial that stands only if it lowers the
    // robust objective (IncrementalGnc::update): a group of false loop
    // closures corroborates itself, but cannot bend a map whose true loop
    // closures it contradicts. 0: corroboration never lands one.
    int support_radius = 5;
  };

  Schedule schedule;
  InnerSolver solver;
  Window window;
  Rejection rejection;
};

// Parsing for command lines and parameter servers; throw std::invalid_argument
// naming the accepted values.
ScheduleKind parseSchedule(const std::string& name);
DistanceConvention parseDistanceConvention(const std::string& name);
ResetPolicy parseResetPolicy(const std::string& name);
Classification parseClassification(const std::string& name);
std::string toString(ScheduleKind kind);
std::string toString(DistanceConvention convention);
std::string toString(ResetPolicy policy);
std::string toString(Classification classification);

// Throws std::invalid_argument naming the offending field if it is out of
// range or inconsistent with another.
void validate(const GncOptions& options);

}  // namespace core
}  // namespace agnc_pgo
