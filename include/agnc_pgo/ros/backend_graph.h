// The back-end's state: the core IncrementalGnc engine plus what ROS adds
// (keyframe stamps and odometry poses, loop-closure metadata, held loop
// closures, counters). Owned and used by the worker thread only; no locking.
#pragma once

#include <deque>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <ros/time.h>

#include "agnc_pgo/core/incremental_gnc.h"
#include "agnc_pgo/ros/backend_parameters.h"
#include "agnc_pgo/ros/graph_io.h"
#include "agnc_pgo/ros/graph_snapshot.h"
#include "agnc_pgo/ros/keyframe_selector.h"
#include "agnc_pgo/ros/loop_closure_matcher.h"

namespace agnc_pgo {
namespace ros_backend {

// Validated inputs (the callbacks checked NaN, quaternions, covariances).
struct OdometryInput {
  ros::Time stamp;
  core::Pose pose;                 // odom frame, already in the graph's dimension
  Eigen::MatrixXd information;     // core order; empty = parameters
};

struct LoopClosureInput {
  ros::Time from_stamp, to_stamp;
  core::Pose measurement;          // already in the graph's dimension
  Eigen::MatrixXd information;     // core order
  std::string source;
  double score = 0.0;
  double received = 0.0;           // steady-clock seconds, for latency
};

struct Counters {
  unsigned odometry_messages = 0, loop_closure_messages = 0;
  unsigned rejected_odometry = 0, rejected_loop_closures = 0, dropped_loop_closures = 0;
  unsigned failed_updates = 0;
  unsigned first_estimates = 0;  // updates that published a first estimate (anytime)
  unsigned idle_refinements = 0;  // idle refinements run to convergence and published
  unsigned last_gnc_steps = 0;
  double last_update_ms = 0.0;
  std::string last_warning;
};

class BackendGraph {
 public:
  explicit BackendGraph(const BackendParameters& parameters);

  // Returns a warning (empty = accepted). `keyframe` tells whether a node was added.
  std::string addOdometry(const OdometryInput& input, bool* keyframe);
  // Adds the loop closure, holds it (endpoints not seen yet), or returns why
  // it was rejected. `added` tells whether it entered the engine.
  std::string addLoopClosure(const LoopClosureInput& input, bool* added);
  // Retries held loop closures; drops those older than the hold time
  // (returns one warning per drop). Received times of added ones go to `added`.
  std::vector<std::string> retryHeld(double now, std::vector<double>* added);

  // Runs the engine if anything is pending. On an exception or a non-finite
  // estimate, rolls back to the last good estimate (dropping the loop
  // closures added since) and returns false with `error` set.
  // `first_estimate`: IncrementalGnc::update()'s anytime report, called
  // only while every pose is finite.
  bool update(core::UpdateStats* stats, std::string* error, const std::function<void()>& first_estimate = {});
  bool optimize(core::UpdateStats* stats, std::string* error);
  // One iteration of the engine's idle refinement
  // (IncrementalGnc::refineIdle()) under the same guard; false when it had
  // nothing to do or failed (then `error` is set and idle refinement waits
  // for the next successful update, so a failing one is not retried).
  bool refineIdle(std::string* error);
  // Idle refinement still has work (the estimate will move a little more).
  bool refining() const { return engine_ && !idle_refinement_failed_ && engine_->hasIdleWork(); }
  // Throws std::invalid_argument. Back to AUTO, the loop closures whose
  // classification differs from before the overrides graduate again (their
  // decision was made against a map the overrides had bent); returns how many.
  int setOverride(int index, core::LoopOverride mode);
  // The first loop closure between the keyframes at these stamps (either
  // order, within ~stamp_tolerance), or -1.
  int findLoopClosure(const ros::Time& from_stamp, const ros::Time& to_stamp) const;
  void reset();
  // The runtime parameters of `next` (readRuntimeParameters) take effect.
  // When a gnc option changed, the engine is rebuilt with the new options
  // from its exact state (the ~load_graph path: estimate, every loop
  // closure's graduation and override; loop closures still pending stay
  // pending, overrides not yet solved stay to be solved) and returns true;
  // the existing loop closures are reclassified at the current estimate.
  // Throws std::invalid_argument, leaving the graph and parameters as they were.
  bool setParameters(const BackendParameters& next);

  SavedGraph save() const;
  // Replaces the graph (throws, leaving it intact, if `saved` is inconsistent).
  void load(const SavedGraph& saved);

  GraphSnapshotPtr snapshot(bool with_edges) const;
  core::Pose mapToOdom() const;

  int numNodes() const { return engine_ ? engine_->numPoses() : 0; }
  int numLoopClosures() const { return engine_ ? static_cast<int>(engine_->loopClosures().size()) : 0; }
  int pendingLoopClosures() const { return engine_ ? engine_->pendingLoopClosures() : 0; }
  int heldLoopClosures() const { return static_cast<int>(held_.size()); }
  const core::IncrementalGnc* engine() const { return engine_.get(); }
  const std::vector<ros::Time>& stamps() const { return matcher_.stamps(); }
  // Totals since the last reset (an engine rebuilt by setParameters or a
  // roll-back carries them on).
  long totalIterations() const { return carried_iterations_ + engine_->totalIterations(); }
  long totalGncSteps() const { return carried_gnc_steps_ + engine_->totalGncSteps(); }

 private:
  struct LoopMeta {
    ros::Time from_stamp, to_stamp;
    std::string source;
    double score = 0.0;
  };
  struct LastGood {
    core::Poses estimate;
    std::vector<core::LoopClosureState> loops;
  };

  std::string tryAddLoop(const LoopClosureInput& input, bool* added, bool* hold);
  void rememberGood();
  void rollBack();
  void rememberOdometry(const OdometryInput& input);
  // Runs a solve; a throw or a non-finite estimate rolls back to the last
  // good state and reports `what` failed.
  bool guardedSolve(const std::string& what, const std::function<core::UpdateStats()>& solve,
                    core::UpdateStats* stats, std::string* error);
  std::unique_ptr<core::IncrementalGnc> build(const SavedGraph& saved) const;
  // Replaces the engine by one rebuilt from this graph's state, carrying
  // over what the state does not hold (the totals).
  void adopt(std::unique_ptr<core::IncrementalGnc> engine);
  void setEngineOverride(int index, core::LoopOverride mode);

  BackendParameters parameters_;
  Eigen::MatrixXd prior_information_;
  Eigen::MatrixXd odometry_information_;
  std::unique_ptr<core::IncrementalGnc> engine_;
  KeyframeSelector selector_;
  LoopClosureMatcher matcher_;
  core::Poses odom_poses_;
  // The last accepted odometry message's position (keyframe or not), for
  // ~max_odometry_jump; compared with the last *accepted* one so that a
  // single wild message does not get its well-behaved successor rejected.
  bool has_last_odometry_ = false;
  Eigen::Vector3d last_odometry_position_ = Eigen::Vector3d::Zero();
  std::vector<LoopMeta> loop_meta_;
  std::deque<LoopClosureInput> held_;
  Eigen::MatrixXd accumulated_covariance_;  // message covariances of skipped odometry
  LastGood last_good_;
  bool idle_refinement_failed_ = false;  // since the last successful update
  // Every loop closure's classification just before the first of the
  // FORCE overrides now in force (empty when none is).
  std::vector<bool> decisions_before_overrides_;
  // For ~pose_graph: successful updates so far, and per loop closure its
  // last classification / graduation and the update that made it.
  struct Decision {
    bool inlier = true, graduating = false;
    long update = 0;
  };
  void noteDecisions();
  long updates_ = 0;
  std::vector<Decision> decisions_;
  // Loop closures whose override changed since the last update (the engine
  // restarts them in the next one; a rebuild must ask again).
  std::vector<int> restarted_;
  // Carried over from engines replaced by adopt().
  long carried_iterations_ = 0, carried_gnc_steps_ = 0;
};

}  // namespace ros_backend
}  // namespace agnc_pgo
