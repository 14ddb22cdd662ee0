// IncrementalGnc's fold check (incremental_gnc.h, FoldCheck): in idle time,
// a second estimate of the whole map from a global start, adopted where the
// robust objective ends lower than the engine's own.
//
// Why. Every decision of the engine is judged on the estimate of the moment.
// On a map with heavy rotation noise (M3500b, 0.25 rad per edge) a cycle of
// hundreds of poses is so uncertain that a false loop closure the map
// explains at few-to-one odds lands, bends the map, and the loop closures
// after it are judged on the bent map. Later evidence may push the false one
// out again, but the estimate stays in the fold: a local minimum of the
// objective whose classification can even be right (M3500b at 30 %, seed 1:
// precision 1.0, recall 0.999, 12.7 m from the ground truth, where the
// objective's minimum next to the truth is lower). Least squares started at
// the odometry falls into such minima too, which is why the replay's
// reference starts from a global initialisation (global_initialization.h).
//
// The hypothesis tested is that the kept loop closures that no kept
// neighbour corroborates (PCM's pairwise test, loop_consistency.h) are what
// bent the map; a place seen again yields runs of mutually consistent loop
// closures, a false one rarely has a consistent neighbour. Stages, one
// whole-graph iteration per refineIdle() call:
//   start          the global initialisation over the odometry and the
//                  corroborated kept loop closures (and, where odometry
//                  chains are several, a kept one attaching each chain
//                  that nothing else in the start attaches);
//   least squares  those at weight 1, every other loop closure left out;
//   robust         every loop closure on Geman-McClure's weights at its mu,
//                  also those the start did not hold, so that they can pull
//                  the map back to them (but not those of negligible
//                  weight, as in the engine: dormant_weight);
//   classified     the engine's own weighting (refresh(): full weight
//                  within the gate, left out beyond it); at convergence the
//                  objective decides, as it decides every landing trial.
// Between calls the engine's own state is back in place (restoreState), so
// everything outside sees the engine's estimate until a verdict adopts the
// second one.
#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <vector>

#include "agnc_pgo/core/global_initialization.h"
#include "agnc_pgo/core/incremental_gnc.h"
#include "agnc_pgo/core/loop_consistency.h"
#include "incremental_gnc_internal.h"

namespace agnc_pgo {
namespace core {
namespace {

// The second estimate must end lower than the engine's by more than
// round-off in the objective's sum (the tie rule of optimizeBatchGlobal).
constexpr double kRelativeTie = 1e-9;

using internal::newerEnd;

// Which poses the edges added so far connect (union-find).
class Components {
 public:
  explicit Components(int n) : parent_(n) {
    for (int i = 0; i < n; ++i) parent_[i] = i;
  }
  int root(int i) {
    while (parent_[i] != i) i = parent_[i] = parent_[parent_[i]];
    return i;
  }
  // False if a and b were connected already.
  bool join(int a, int b) {
    a = root(a);
    b = root(b);
    if (a == b) return false;
    parent_[std::max(a, b)] = std::min(a, b);
    return true;
  }

 private:
  std::vector<int> parent_;
};

}  // namespace

std::vector<bool> IncrementalGnc::corroboratedInliers() const {
  std::vector<bool> corroborated(loops_.size(), false);
  const int radius = options_.rejection.support_radius;
  if (radius == 0) return corroborated;
  // The noise the whole map shows, as the arrival test scales its pairs by
  // the noise its window shows.
  const double variance_factor = solver_.varianceFactor(0, {});
  const auto kept = [this](int k) {
    return loops_[k].override_mode == LoopOverride::kAuto && loops_[k].inlier;
  };
  for (int index = 0; index < static_cast<int>(loops_.size()); ++index) {
    if (!kept(index) || corroborated[index]) continue;
    const Edge& e = loops_[index].edge;
    const int last = std::min(newerEnd(e) + radius, static_cast<int>(loops_by_newer_pose_.size()) - 1);
    for (int p = std::max(0, newerEnd(e) - radius); p <= last && !corroborated[index]; ++p) {
      for (int other : loops_by_newer_pose_[p]) {
        if (other == index || !kept(other) || !areNeighbours(e, loops_[other].edge, radius) ||
            !pairAgrees(e, loops_[other].edge, variance_factor))
          continue;
        corroborated[index] = corroborated[other] = true;
        break;
      }
    }
  }
  return corroborated;
}

bool IncrementalGnc::startFoldCheck() {
  // Without the pairwise test (support_radius 0) there is no hypothesis.
  if (options_.rejection.support_radius == 0) return false;
  std::vector<bool> in_start = corroboratedInliers();
  for (size_t k = 0; k < loops_.size(); ++k)
    in_start[k] = in_start[k] || loops_[k].override_mode == LoopOverride::kForceInlier;
  keepAttachments(&in_start);
  bool hypothesis = false;  // a kept loop closure left out of the start
  for (size_t k = 0; k < loops_.size(); ++k)
    hypothesis = hypothesis || (loops_[k].override_mode == LoopOverride::kAuto && loops_[k].inlier && !in_start[k]);
  if (!hypothesis) return false;
  PoseGraph graph;
  graph.dimension = dimension_;
  graph.poses = poses();  // pose 0 holds the gauge
  graph.fixed = {0};
  graph.edges = odometry_;
  for (size_t k = 0; k < loops_.size(); ++k)
    if (in_start[k]) graph.edges.push_back(loops_[k].edge);
  for (Edge& e : graph.edges) e.is_outlier = false;  // a replay's labels are not the engine's to read
  Poses start;
  try {
    start = globalInitialization(graph);
  } catch (const std::invalid_argument&) {
    return false;  // a chain that no kept loop closure attaches
  } catch (const std::runtime_error&) {
    return false;  // a singular linear system: no global start
  }
  for (int i = 0; i < numPoses(); ++i) solver_.setPose(i, start[i]);
  for (size_t k = 0; k < loops_.size(); ++k) {
    LoopClosure& loop = loops_[k];
    if (loop.override_mode != LoopOverride::kAuto) continue;
    setDormant(&loop, !in_start[k]);
    setFullWeight(&loop, in_start[k]);
  }
  fold_check_ = std::make_unique<FoldCheck>();
  return true;
}

void IncrementalGnc::keepAttachments(std::vector<bool>* in_start) const {
  // A second odometry chain (a gap in the odometry) that only
  // uncorroborated loop closures attach would have no place in the global
  // start; its kept attachments stay in (the first of them in arrival order
  // for each chain joined), since the test cannot ask whether a chain's
  // only link bent the map.
  Components components(numPoses());
  for (const Edge& e : odometry_) components.join(e.from, e.to);
  for (size_t k = 0; k < loops_.size(); ++k)
    if ((*in_start)[k]) components.join(loops_[k].edge.from, loops_[k].edge.to);
  for (size_t k = 0; k < loops_.size(); ++k) {
    const LoopClosure& loop = loops_[k];
    if ((*in_start)[k] || loop.override_mode != LoopOverride::kAuto || !loop.inlier) continue;
    if (components.join(loop.edge.from, loop.edge.to)) (*in_start)[k] = true;
  }
}

void IncrementalGnc::stepFoldCheck() {
  const Snapshot own = snapshot(0);
  if (!fold_check_) {
    if (!startFoldCheck()) {
      fold_check_due_ = false;
      return;
    }
  } else {
    restoreState(fold_check_->alternative);
    FoldCheck& check = *fold_check_;
    if (idleCheckIteration(&check.iterations)) {
      switch (check.stage) {
        case FoldCheck::Stage::kLeastSquares:
          // Those of negligible weight stay out, as in the engine
          // (dormant_weight): a random false loop closure is a long-range
          // edge of fill-in in every factorisation.
          for (LoopClosure& loop : loops_) {
            if (loop.override_mode != LoopOverride::kAuto) continue;
            setFullWeight(&loop, false);
            setDormant(&loop, solver_.weight(loop.factor) < options_.rejection.dormant_weight);
          }
          check.stage = FoldCheck::Stage::kRobust;
          break;
        case FoldCheck::Stage::kRobust:
          classifyAll();
          check.stage = FoldCheck::Stage::kClassified;
          break;
        case FoldCheck::Stage::kClassified:
          classifyAll();
          fold_check_due_ = false;
          if (solver_.objective(0) < own.objective - kRelativeTie * std::abs(own.objective)) {
            adoptFoldCheck();
            return;
          }
          fold_check_.reset();
          restoreState(own);
          return;
      }
    }
  }
  fold_check_->alternative = snapshot(0);
  restoreState(own);
}

void IncrementalGnc::adoptFoldCheck() {
  fold_check_.reset();
  for (size_t k = 0; k < loops_.size(); ++k) {
    LoopClosure& loop = loops_[k];
    if (loop.override_mode != LoopOverride::kAuto) continue;
    if (loop.inlier) {
      loop.uncorroborated = false;
      loop.undone = false;
      paths_ruled_out_.erase(static_cast<int>(k));
    } else {
      loop.landed = false;
    }
  }
  unrefined_step_ = 0.0;
}

}  // namespace core
}  // namespace agnc_pgo
