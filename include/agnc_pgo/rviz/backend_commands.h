// The back-end's services as the rviz panel calls them (no Qt): each call
// waits at most a few seconds for the service and returns success and the
// back-end's message (or why it could not be called).
#pragma once

#include <string>

namespace agnc_pgo {
namespace panel {

struct CommandOutcome {
  bool success = false;
  std::string message;
};

class BackendCommands {
 public:
  explicit BackendCommands(std::string backend = "/agnc_pgo_backend", double timeout = 5.0)
      : backend_(std::move(backend)), timeout_(timeout) {}

  const std::string& backend() const { return backend_; }
  // mode: agnc_pgo::SetLoopClosureStatus::Request::AUTO / FORCE_INLIER / FORCE_OUTLIER
  CommandOutcome setOverride(int loop_index, int mode) const;
  CommandOutcome pause(bool paused) const;
  CommandOutcome optimize() const;
  CommandOutcome saveGraph(const std::string& filename) const;
  CommandOutcome loadGraph(const std::string& filename) const;
  CommandOutcome saveTrajectory(const std::string& filename) const;

 private:
  template <typename Service>
  CommandOutcome call(const std::string& name, Service* service) const;
  std::string backend_;
  double timeout_;
};

}  // namespace panel
}  // namespace agnc_pgo
