// The incremental adaptive-GNC engine (ALGORITHM.md §4).
//
// Poses arrive with odometry (no solve: the new pose is initialised by
// composing the odometry and the previous optimum stays optimal); loop
// closures are queued and update() graduates them: every GNC step sets the
// mu of each graduating loop closure from its schedule and takes one
// warm-started Gauss-Newton iteration; when none is graduating any more, a
// few iterations settle the estimate, the loop closures that graduated adapt
// their starting point, and they are classified.
//
// The engine is deterministic for a given input and options.
#pragma once

#include <functional>
#include <limits>
#include <memory>
#include <unordered_map>
#include <vector>

#include "agnc_pgo/core/gnc_options.h"
#include "agnc_pgo/core/graduation_schedule.h"
#include "agnc_pgo/core/loop_consistency.h"
#include "agnc_pgo/core/noise_scale.h"
#include "agnc_pgo/core/pose_graph.h"
#include "agnc_pgo/core/sparse_pose_graph_solver.h"

namespace agnc_pgo {
namespace core {

// A user's decision that overrides the GNC classification of one loop closure.
enum class LoopOverride { kAuto, kForceInlier, kForceOutlier };

struct LoopClosure {
  Edge edge;
  int factor = -1;            // the solver's factor id
  GraduationState graduation;
  double distance = 0.0;      // last whitened residual norm r
  // Rejected on arrival: a confident outlier by its own covariance (beyond
  // q(0.9)) that no neighbouring loop closure corroborated (yet) and that
  // the map does not explain better than chance (loop_prediction.h); or
  // landed, and undone because the trial raised the objective (update()).
  bool uncorroborated = false;
  // Landed in a trial that raised the objective and was undone: the map's
  // test proposed it and the objective said no, so a tighter map alone does
  // not propose it again; a corroborating loop closure arriving later does.
  bool undone = false;
  // Landed on its whole cycle by a trial that stood. A later group of loop
  // closures that the map rejects because of it may release it (update()).
  bool landed = false;
  // How many times the map has judged it (explainedByTheMap): each time is
  // another chance for a false loop closure to look explained, so the k-th
  // judgement asks for a likelihood ratio above k.
  int map_judgements = 0;
  double weight = 1.0;        // weight in the solve: the kernel's at the current mu, or 1 (full_weight)
  bool inlier = true;         // classification (GncOptions::Schedule::classification)
  bool dormant = false;       // out of the linear system (see GncOptions::Rejection::dormant_weight)
  // In the solve at weight 1, not the kernel's: its graduation ended with
  // a residual the chi-square test accepts under its stated covariance.
  bool full_weight = false;
  LoopOverride override_mode = LoopOverride::kAuto;
};

// What the engine decided about a loop closure beyond what the estimate
// shows: what loopStates() reports, a saved graph keeps, and restore() puts
// back, so that an engine rebuilt from them goes on as the saved one would.
struct LoopClosureState {
  GraduationState graduation;
  LoopOverride override_mode = LoopOverride::kAuto;
  bool uncorroborated = false;  // LoopClosure::uncorroborated
  bool undone = false;          // LoopClosure::undone
  bool landed = false;          // LoopClosure::landed
  int map_judgements = 0;       // LoopClosure::map_judgements
};

struct UpdateStats {
  int gnc_steps = 0;       // steps with at least one graduating loop closure
  int iterations = 0;      // Gauss-Newton iterations (= solves)
  int refinement_iterations = 0;  // of which on the whole graph after the window
  int graduated = 0;       // loop closures that graduated (new + reset)
  int first_variable = 0;  // oldest pose that was free in this update
  bool converged = false;  // mean step per pose below options.convergence_step at the end
};

class IncrementalGnc {
 public:
  IncrementalGnc(int dimension, const GncOptions& options);

  int dimension() const { return dimension_; }
  const GncOptions& options() const { return options_; }
  const GraduationSchedule& schedule() const { return schedule_; }

  // Pose 0 and its prior (the gauge). Must be the first call.
  void addFirstPose(const Pose& value, const Eigen::MatrixXd& information);
  // A new pose held by a prior: pose 0 (as addFirstPose), or the start of a
  // new odometry chain (a second session), whose prior is a weak gauge until
  // loop closures attach it. Throws std::invalid_argument (graph unchanged)
  // on a non-finite value or non-positive-definite information.
  void addPoseWithPrior(const Pose& value, const Eigen::MatrixXd& information);
  // Odometry from an existing pose. If edge.to == numPoses() the new pose is
  // created at pose(edge.from) * measurement. Throws std::invalid_argument
  // (graph unchanged) on unknown ids or non-positive-definite information.
  void addOdometry(const Edge& edge);
  // Queues a loop closure for the next update(); returns its index.
  // Throws std::invalid_argument (graph unchanged) like addOdometry.
  int addLoopClosure(const Edge& edge);

  // Brings the estimate up to date. Without queued loop closures or
  // overrides this does nothing (no solve is needed). A far loop closure
  // that the map explained and landed makes another pass judge again the
  // ones rejected as unexplained whose cycles overlap its own. Landing far
  // loop closures is a trial: if it ends higher on the robust objective
  // (SparsePoseGraphSolver::objective) than the estimate before it, the
  // estimate and every loop closure's state return to what they were, the
  // landed ones are rejected and the other new ones are judged again.
  // If they were a group that corroborates itself and the trial pushed
  // loop closures landed earlier beyond the inlier gate, the other
  // hypothesis is tried as well: those landings released, the group landed;
  // it stands if it ends lower than the estimate before it.
  //
  // Anytime: `first_estimate`, if given, is called (on this thread, at most
  // once) as soon as the estimate holds every new loop closure's effect on
  // its window, when work that does not change that effect is still to
  // come -- the whole-graph refinement that lets the older poses follow, or
  // another pass for loop closures the landing made explicable -- or, when
  // far loop closures arrive, before the map's prediction that judges them
  // and before the trial that lands them (the estimate that stands if they
  // are refused, and within their own noise of what any near loop closures
  // arriving with them would make it; both work on whole cycles and are the
  // slowest updates there are). The caller
  // may read poses() there and publish them (loop closures are classified
  // only when update() returns). The results are the same with or without it.
  UpdateStats update(const std::function<void()>& first_estimate = {});
  // Iterates on the whole graph until convergence (at most `max_iterations`).
  UpdateStats optimize(int max_iterations = 20);
  // For idle time (the node between messages, the replay at the end of a
  // log): one whole-graph iteration towards the converged estimate that the
  // updates leave unfinished -- an update refines the whole graph only once
  // its windows' net displacement amounts to convergence_step per pose, and
  // then for at most max_settle_iterations. Returns false, doing nothing,
  // once the estimate has converged since the last update() that solved,
  // and while loop closures or overrides wait for update() (restore()
  // leaves a saved estimate as it was saved). At convergence every loop
  // closure is classified again. Then, if kept loop closures stand that no
  // neighbour corroborates, the fold check (incremental_gnc_fold_check.cc):
  // a second estimate from a global start, adopted where the robust
  // objective ends lower. One call costs one whole-graph iteration (or the
  // global initialisation), so a message that arrives meanwhile waits for
  // at most that; between calls the engine holds its own estimate, and any
  // change to the graph discards an unfinished check. Last, the full-weight
  // check (incremental_gnc_full_weight.cc): the kept loop closures beyond
  // the chi-square gate tried at full weight, kept there where least squares
  // brings them within it and everything already at full weight stays so.
  bool refineIdle();
  // Whether refineIdle() has work: the estimate has not converged, or has
  // not been checked, since the last update() that solved, and nothing
  // waits for update().
  bool hasIdleWork() const {
    return (!idle_converged_ || fold_check_due_ || full_weight_check_due_) && options_.window.global_refinement && pending_.empty() &&
           needs_restart_.empty();
  }

  void setOverride(int loop, LoopOverride mode);
  // Recomputes distance, weight and classification of every loop closure at
  // the current estimate (O(loop closures)).
  void classifyAll();

  // In loopClosures() order, what restore() needs besides the estimate.
  std::vector<LoopClosureState> loopStates() const;
  // Restores a saved state without solving (loading a saved graph, rolling
  // back a failed update): the estimate (one pose per node) and, in
  // loopClosures() order, each loop closure's state (loopStates()).
  // Clears pending work and reclassifies. Throws std::invalid_argument on a
  // size mismatch. (Implemented in incremental_gnc_restore.cc.)
  void restore(const Poses& estimate, const std::vector<LoopClosureState>& loops);

  int numPoses() const { return solver_.numPoses(); }
  Pose pose(int id) const { return solver_.pose(id); }
  Poses poses() const;
  const std::vector<LoopClosure>& loopClosures() const { return loops_; }
  const std::vector<Edge>& odometry() const { return odometry_; }
  int pendingLoopClosures() const { return static_cast<int>(pending_.size()); }

  // Per tangent component (translation first): how many times, in
  // variance, the stated covariances understate the noise, as the pairs of
  // neighbouring loop closures show it for translation and for rotation
  // (noise_scale.h); 1 unless they prove it larger. Every judgement and the
  // kernel use the stated covariances widened by this.
  const Eigen::VectorXd& noiseScale() const { return solver_.noiseScale(); }

  // Totals since construction.
  long totalIterations() const { return total_iterations_; }
  long totalGncSteps() const { return total_gnc_steps_; }

 private:
  // What update() decided and which poses are free (see update()).
  struct UpdatePlan {
    int first = 0;               // oldest free pose
    int oldest = 0;              // oldest endpoint of what changed
    std::vector<int> decided;    // new loop closures accepted or rejected on arrival
    std::vector<int> accepted;   // ... of which accepted
    std::vector<int> to_graduate;  // new loop closures that graduate
    std::vector<int> cycles;     // ... of which need their whole cycle free to land
    std::vector<int> explained;  // ... of which came alone and the map explained
    std::vector<int> graduating;  // all that graduate now (new + reset); shrinks as they finish
    std::vector<int> graduated;  // all that started graduating in this update
    std::vector<int> still_dormant;  // reset, but left out as dormant
    bool moves = false;          // something will pull the estimate
    double last_step = std::numeric_limits<double>::infinity();
  };

  // What a pass that lands far loop closures may have to return to (see
  // updatePass()).
  struct Snapshot {
    int first = 0;      // the oldest free pose of the pass
    Poses estimate;     // poses first ..
    struct LoopState {  // what a pass may change of a loop closure
      GraduationState graduation;
      double distance, weight;
      bool uncorroborated, undone, landed, inlier, dormant, full_weight;
    };
    std::vector<LoopState> loops;
    double objective = 0.0;  // SparsePoseGraphSolver::objective(first)
  };

  // One pass of update(): judges what is pending and brings the estimate up
  // to date; returns what the next pass judges: the loop closures rejected
  // as unexplained that a far one the map explained makes worth judging
  // again, or after a failed trial the other new ones.
  // Calls and clears *first_estimate (update()) once the pass's window
  // result stands, if work is left after it, or before far work
  // (reportBeforeFarWork).
  std::vector<int> updatePass(UpdateStats* stats, std::function<void()>* first_estimate);
  // Calls and clears *first_estimate before far work (the map's prediction,
  // a landing's trial): the estimate of the moment is the one that stands
  // if the far loop closures are refused, and every near one arriving with
  // them already agrees with it within its own noise (m < q(0.9)).
  void reportBeforeFarWork(std::function<void()>* first_estimate) const;
  Snapshot snapshot(int first) const;
  // Returns to `before`, rejects the far loop closures the trial landed and
  // returns the other pending ones, to be judged again.
  std::vector<int> rollBack(const Snapshot& before, const UpdatePlan& plan);
  // Rejected at mu = 1 after a trial the objective refused; judged again only
  // with a corroborating loop closure.
  void rejectAsUndone(int index);
  // After a trial that landed a corroborated group and was refused: the
  // loop closures landed earlier, inliers before the trial, in the trial's
  // window (the group's own excepted).
  std::vector<int> competingLandings(const Snapshot& before, const UpdatePlan& plan) const;
  // The other hypothesis for a refused group: the competing landings were
  // wrong. Lands the group without them; keeps the result if it ends lower
  // on the objective than the estimate before (the released ones that the
  // map then contradicts are rejected, the others stay landed), else returns
  // to it. True if it stands.
  bool releaseAndLand(const std::vector<int>& group, const std::vector<int>& released, UpdateStats* stats,
                      std::function<void()>* first_estimate);
  // Loop closures rejected on arrival as unexplained (not undone trials) whose cycle overlaps
  // one of `landed`'s and that the map, tighter now, explains.
  std::vector<int> explainedAfterLanding(const std::vector<int>& landed);
  // The stated covariance of the odometry step that created a pose (empty
  // at the start of a chain), for the pairwise cycle test.
  StepCovariance odometryStep() const;
  // Adds the cycle errors of a new loop closure and its earlier neighbours
  // to the noise estimate; re-estimates it each time the pairs double.
  void sampleNoise(int index);
  // Scales every stated covariance to the new noise scale; the loop closures
  // whose verdict at the estimate it changes are judged again as if they
  // had just arrived.
  void applyNoiseScale(double translation, double rotation);
  // A stated information or covariance under the current noise scale.
  Eigen::MatrixXd widenedInformation(const Eigen::MatrixXd& information) const;
  Eigen::MatrixXd widenedCovariance(const Eigen::MatrixXd& covariance) const;

  // The steps of a pass, in order. `before_prediction` is called just
  // before the map's prediction factorises the cycles of far loop closures
  // (the slow part of judging them).
  UpdatePlan judgeArrivals(const std::function<void()>& before_prediction);
  void judgeFar(const std::vector<int>& far, UpdatePlan* plan, const std::function<void()>& before_prediction);
  void land(int index, UpdatePlan* plan);
  // variance_factor() is the a-posteriori variance of unit weight the
  // pairwise test scales the stated covariances by.
  std::vector<int> corroboratingLoops(int index, const std::vector<int>& far,
                                      const std::function<double()>& variance_factor) const;
  // The rejected or arriving loop closures linked to this one by a chain of
  // corroborating neighbours (corroboratingLoops, transitively).
  std::vector<int> consistentRun(int index, const std::vector<int>& far,
                                 const std::function<double()>& variance_factor) const;
  // For each far loop closure, whether the map's uncertainty between its
  // endpoints explains it better than chance (loop_prediction.h).
  std::vector<bool> explainedByTheMap(const std::vector<int>& loops,
                                      const std::function<void()>& before_prediction = {});
  // Whether the path that last ruled the loop closure out (paths_ruled_out_)
  // still does at the current estimate: usable (none of its factors judged
  // with it, dormant or of no weight) and its bound on the map's odds <= 0.
  bool stillRuledOut(int index, const std::vector<int>& judged_sorted, double variance_factor,
                     double log_volume) const;
  // A path of the map between the loop closure's endpoints whose bound on
  // the map's odds is <= 0, or empty if none was found: first the kept
  // tree's path to its root continued to the newer endpoint, then the
  // shortest path (which, if it rules the loop closure out where the tree's
  // did not, becomes the new tree's).
  std::vector<int> rulingOutPath(int index, SparsePoseGraphSolver::PathSearch* paths,
                                 const std::vector<int>& judged_sorted, double variance_factor, double log_volume);
  void planWindow(UpdatePlan* plan) const;
  void selectGraduating(UpdatePlan* plan);
  // The GNC steps and the settle iterations of a pass on its window.
  void solveWindow(UpdatePlan* plan, UpdateStats* stats);
  void runGncSteps(UpdatePlan* plan, UpdateStats* stats);
  // Adds what the window moved to the displacement not yet refined; true
  // if it calls for the whole-graph refinement (refine()).
  bool needsRefinement(const UpdatePlan& plan, const Poses& window_before);
  void refine(UpdateStats* stats);
  void finish(const UpdatePlan& plan, const UpdateStats& stats);

  void validateEdge(const Edge& edge, bool allow_new_pose) const;
  FactorMode robustMode() const;
  // The loop closure's distance under the configured convention, now.
  double distance(const LoopClosure& loop) const;
  void refresh(LoopClosure* loop);
  void applyOverride(LoopClosure* loop);
  void setDormant(LoopClosure* loop, bool dormant);
  void setFullWeight(LoopClosure* loop, bool full_weight);
  bool staysDormant(const LoopClosure& loop) const;
  void acceptConsistent(const std::vector<int>& graduating);
  void finishAt(LoopClosure* loop, double mu);  // graduation over at this mu
  bool mayRefine(const UpdatePlan& plan) const;
  Poses windowPoses(const UpdatePlan& plan) const;
  int maxSettleIterations() const;
  IterationResult iterateOnce(int first, UpdateStats* stats);
  // Iterates until the mean step falls below convergence_step (at most
  // max_iterations); sets stats->converged.
  void settle(int first_variable, int max_iterations, double last_step, UpdateStats* stats);
  // settle() on the whole graph with step extension (refine(), optimize()).
  void settleWholeGraph(int max_iterations, UpdateStats* stats);
  void rearmIdleRefinement();  // the estimate changed: refineIdle() has work
  // One whole-graph iteration of an idle check's stage (the fold check's,
  // the full-weight check's); true at the stage's convergence, or after
  // kMaxIdleIterations, when `stage_iterations` starts again from 0.
  bool idleCheckIteration(int* stage_iterations);

  // The fold check (incremental_gnc_fold_check.cc). An estimate reached
  // update by update can end in a fold -- a worse minimum of the robust
  // objective -- while its classification is nearly right: on a map with
  // heavy rotation noise, loop closures the map explained at few-to-one
  // odds bend it, and the ones after are judged on the bent map. The check
  // tests the hypothesis that the kept loop closures no neighbour
  // corroborates are what bent it: least squares over the odometry and the
  // corroborated ones from a global initialisation (the reference's own
  // safeguard against drift, global_initialization.h), then the robust
  // objective over every loop closure from there (Geman-McClure's weights;
  // only those below dormant_weight left out), then the engine's
  // classification; the second estimate
  // replaces the first only if it ends lower on the objective.
  struct FoldCheck {
    enum class Stage { kLeastSquares, kRobust, kClassified };
    Stage stage = Stage::kLeastSquares;
    Snapshot alternative;  // the second estimate and its loop closures' states, between calls
    int iterations = 0;    // in this stage
  };
  // One call's work (refineIdle()): the start, or one iteration of the
  // second estimate; at the end of its last stage, the verdict.
  void stepFoldCheck();
  // Sets the global start and the least-squares stage's weights; false if
  // there is nothing to test or no global start.
  bool startFoldCheck();
  // Adds to the start's loop closures the kept ones that attach an odometry
  // chain nothing in it connects to pose 0.
  void keepAttachments(std::vector<bool>* in_start) const;
  // Per loop closure: kept (inlier, automatic) and agreeing with a kept
  // neighbour (pairAgrees).
  std::vector<bool> corroboratedInliers() const;
  // Whether PCM's pairwise test accepts two neighbouring loop closures
  // (loop_consistency.h) at the current estimate, under the noise scale and
  // this variance factor.
  bool pairAgrees(const Edge& a, const Edge& b, double variance_factor) const;
  // Poses (from s.first) and every loop closure's state as in s.
  void restoreState(const Snapshot& s);
  // The second estimate stands: the loop closures it keeps are no longer
  // rejected ones, those it rejects no longer landed.
  void adoptFoldCheck();

  // The full-weight check (incremental_gnc_full_weight.cc). A kept loop
  // closure counts at full weight where its residual is within the
  // chi-square gate (refresh()), judged at the current estimate; on a
  // long-drift map both least squares, where it is within, and
  // Geman-McClure's weights, which let the odometry pull it beyond, are
  // self-consistent. The check tries the candidates -- kept, decided at
  // mu = 1, beyond the gate -- at full weight on the whole graph; those
  // still beyond the gate at convergence go back to their kernel weight and
  // the graph converges again, until none is; the result stands if every
  // loop closure trusted at full weight before is still within its gate
  // and every candidate still kept.
  struct FullWeightCheck {
    std::vector<int> candidates;  // loop closures tried at full weight
    std::vector<int> trusted;     // those at full weight before
    Snapshot alternative;         // the estimate and states under test, between calls
    int iterations = 0;           // since the last convergence
  };
  // One call's work (refineIdle()): the start, or one iteration; at each
  // convergence the candidates beyond the gate go back to their kernel
  // weight, and when none does, the verdict.
  void stepFullWeightCheck();
  // Puts the candidates at full weight; false if there are none.
  bool startFullWeightCheck();
  // The candidates at full weight still beyond the gate go back to their
  // kernel weight; false if none does.
  bool demoteBeyondTheGate(const std::vector<int>& candidates);
  // Whether the estimate keeps the trusted loop closures within their gate
  // and the candidates kept.
  bool fullWeightStands(const FullWeightCheck& check) const;
  // A loop closure the graduation has decided at mu = 1 under the automatic
  // classification (refresh() weighs such loop closures by the gate).
  bool decidedAtOne(const LoopClosure& loop) const;
  // Ends unfinished idle checks (the graph they were for has changed).
  void discardIdleChecks() {
    fold_check_.reset();
    full_weight_check_.reset();
  }

  int dimension_;
  GncOptions options_;
  GraduationSchedule schedule_;
  SparsePoseGraphSolver solver_;
  std::vector<Edge> odometry_;
  std::vector<int> odometry_into_;  // per pose p: index in odometry_ of the edge p-1 -> p that created it, or -1
  std::vector<LoopClosure> loops_;
  std::vector<std::vector<int>> loops_by_newer_pose_;  // loop indices by their newer endpoint
  std::vector<int> pending_;       // loop indices queued for the next update
  std::vector<int> needs_restart_; // loop indices whose override changed
  // Per loop closure the map's test ruled out by a path's bound, that path:
  // a loop closure judged again (after a landing) tries it before searching
  // the map for the shortest path. Any path of the map's factors bounds the
  // map's prediction from above, so a bound <= 0 on it decides as the
  // prediction would; only where it no longer does is the map searched.
  std::unordered_map<int, std::vector<int>> paths_ruled_out_;
  // Shortest paths to the newer endpoint of a far loop closure that one of
  // them ruled out, kept for the next ones: most far loop closures end at
  // the newest pose, and a kept path to where the newest pose was, continued
  // by a short search from there, is a path too. A search from the older
  // endpoint would expand most of the map for each random outlier; the tree
  // is searched again only when its path no longer rules out a loop closure
  // that a fresh shortest path does (rulingOutPath).
  SparsePoseGraphSolver::PathTree path_tree_;
  double unrefined_step_ = 0.0;  // window displacements since the last whole-graph refinement
  // refineIdle(): whether the estimate converged since the last solve, and
  // the iterations spent on it so far.
  bool idle_converged_ = true;
  int idle_iterations_ = 0;
  bool fold_check_due_ = false;  // since the last update() that solved
  std::unique_ptr<FoldCheck> fold_check_;  // under way
  bool full_weight_check_due_ = false;  // since the last update() that solved
  std::unique_ptr<FullWeightCheck> full_weight_check_;  // under way
  NoiseScale translation_noise_, rotation_noise_;
  Poses dead_reckoning_;  // per pose: the odometry composed along its chain
  int next_noise_estimate_ = 1;  // samples at which the noise scale is estimated next
  long total_iterations_ = 0;
  long total_gnc_steps_ = 0;
};

}  // namespace core
}  // namespace agnc_pgo
