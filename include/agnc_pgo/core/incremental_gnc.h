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

#include <vector>

#include "agnc_pgo/core/gnc_options.h"
#include "agnc_pgo/core/graduation_schedule.h"
#include "agnc_pgo/core/trajectory_io.h"
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
  double weight = 1.0;        // kernel weight at the current mu
  bool inlier = true;         // classification (distance < q(0.95) under the convention)
  bool dormant = false;       // out of the linear system (see GncOptions::dormant_weight)
  bool supported = false;     // agrees with a neighbouring loop closure (GncOptions::support_radius)
  LoopOverride override_mode = LoopOverride::kAuto;
};

struct UpdateStats {
  int gnc_steps = 0;       // steps with at least one graduating loop closure
  int iterations = 0;      // Gauss-Newton iterations (= solves)
  int refinement_iterations = 0;  // of which on the whole graph after the window
  int factorizations = 0;  // numeric factorisations (>= iterations when damping kicked in)
  int graduated = 0;       // loop closures that graduated (new + reset)
  int first_variable = 0;  // oldest pose that was free in this update
  bool converged = false;  // mean step per pose below options.convergence_step at the end
  double max_mean_step = 0.0;  // largest mean tangent step per free pose of any iteration
};

class IncrementalGnc {
 public:
  IncrementalGnc(int dimension, const GncOptions& options);

  int dimension() const { return dimension_; }
  const GncOptions& options() const { return options_; }
  const GraduationSchedule& schedule() const { return schedule_; }

  // Pose 0 and its prior (the gauge). Must be the first call.
  void addFirstPose(const Pose& value, const Eigen::MatrixXd& information);
  // Odometry from an existing pose. If edge.to == numPoses() the new pose is
  // created at pose(edge.from) * measurement. Throws std::invalid_argument
  // (graph unchanged) on unknown ids or non-positive-definite information.
  void addOdometry(const Edge& edge);
  // Queues a loop closure for the next update(); returns its index.
  // Throws std::invalid_argument (graph unchanged) like addOdometry.
  int addLoopClosure(const Edge& edge);

  // Brings the estimate up to date. Without queued loop closures or
  // overrides this does nothing (no solve is needed).
  UpdateStats update();
  // Iterates on the whole graph until convergence (at most `max_iterations`).
  UpdateStats optimize(int max_iterations = 20);

  void setOverride(int loop, LoopOverride mode);
  // Recomputes distance, weight and classification of every loop closure at
  // the current estimate (O(loop closures)).
  void classifyAll();

  // Restores a saved state without solving (loading a saved graph, rolling
  // back a failed update): the estimate (one pose per node) and, in
  // loopClosures() order, each loop closure's graduation state and override.
  // Clears pending work and reclassifies. Throws std::invalid_argument on a
  // size mismatch. (Implemented in incremental_gnc_restore.cc.)
  void restore(const Poses& estimate, const std::vector<GraduationState>& graduation,
               const std::vector<LoopOverride>& overrides);

  int numPoses() const { return solver_.numPoses(); }
  Pose pose(int id) const { return solver_.pose(id); }
  Poses poses() const;
  const std::vector<LoopClosure>& loopClosures() const { return loops_; }
  const std::vector<Edge>& odometry() const { return odometry_; }
  int pendingLoopClosures() const { return static_cast<int>(pending_.size()); }

  // Totals since construction.
  long totalIterations() const { return total_iterations_; }
  long totalGncSteps() const { return total_gnc_steps_; }

 private:
  void validateEdge(const Edge& edge, bool allow_new_pose) const;
  void refresh(LoopClosure* loop);
  void applyOverride(LoopClosure* loop);
  // How a loop closure sits in the linear system: dormant (out of it) or
  // decoupled (no off-diagonal block); both false = fully in.
  void setSparsity(LoopClosure* loop, bool dormant, bool decoupled);
  bool staysDormant(const LoopClosure& loop) const;
  double dormantWeight(const LoopClosure& loop) const;
  // Marks the loop closure and every neighbour it agrees with as supported.
  void findSupport(int index);
  void acceptConsistent(const std::vector<int>& graduating);
  void acceptAsInlier(LoopClosure* loop);  // mu = 1, graduation over
  // One solver iteration, counted into stats (iterations, steps).
  IterationResult iterateOnce(int first, UpdateStats* stats);
  int settle(int first_variable, int max_iterations, double last_step, UpdateStats* stats);

  int dimension_;
  GncOptions options_;
  GraduationSchedule schedule_;
  SparsePoseGraphSolver solver_;
  std::vector<Edge> odometry_;
  std::vector<LoopClosure> loops_;
  std::vector<std::vector<int>> loops_by_newer_pose_;  // loop indices by their newer endpoint
  std::vector<int> pending_;       // loop indices queued for the next update
  std::vector<int> needs_restart_; // loop indices whose override changed
  double unrefined_step_ = 0.0;  // window displacements since the last whole-graph refinement
  long total_iterations_ = 0;
  long total_gnc_steps_ = 0;
};

}  // namespace core
}  // namespace agnc_pgo
