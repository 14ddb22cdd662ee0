// IncrementalGnc::restore: puts back a saved estimate and loop-closure state
// (used by the ROS back-end to load graphs and to roll back failed updates).
#include <stdexcept>
#include <string>
#include <vector>

#include "agnc_pgo/core/incremental_gnc.h"

namespace agnc_pgo {
namespace core {

std::vector<LoopClosureState> IncrementalGnc::loopStates() const {
  std::vector<LoopClosureState> out;
  out.reserve(loops_.size());
  for (const LoopClosure& loop : loops_)
    out.push_back({loop.graduation, loop.override_mode, loop.uncorroborated, loop.undone, loop.landed,
                   loop.map_judgements});
  return out;
}

void IncrementalGnc::restore(const Poses& estimate, const std::vector<LoopClosureState>& states) {
  if (static_cast<int>(estimate.size()) != numPoses())
    throw std::invalid_argument("restore: " + std::to_string(estimate.size()) + " poses for a graph of " +
                                std::to_string(numPoses()));
  if (states.size() != loops_.size())
    throw std::invalid_argument("restore: loop-closure state for " + std::to_string(states.size()) + " of " +
                                std::to_string(loops_.size()) + " loop closures");
  for (int i = 0; i < numPoses(); ++i) solver_.setPose(i, estimate[i]);
  for (size_t k = 0; k < loops_.size(); ++k) {
    LoopClosure& loop = loops_[k];
    const LoopClosureState& saved = states[k];
    loop.override_mode = saved.override_mode;
    applyOverride(&loop);  // sets the factor mode, clears graduating
    loop.graduation = saved.graduation;
    loop.uncorroborated = saved.uncorroborated;
    loop.undone = saved.undone;
    loop.landed = saved.landed;
    if (saved.map_judgements < 0)
      throw std::invalid_argument("restore: loop closure " + std::to_string(k) + " judged " +
                                  std::to_string(saved.map_judgements) + " times");
    loop.map_judgements = saved.map_judgements;
    solver_.setMu(loop.factor, loop.graduation.mu);
  }
  pending_.clear();
  needs_restart_.clear();
  discardIdleChecks();
  fold_check_due_ = full_weight_check_due_ = false;  // a restored estimate stays as saved
  classifyAll();
}

}  // namespace core
}  // namespace agnc_pgo
