#include "agnc_pgo/rviz/backend_commands.h"

#include <ros/ros.h>
#include <std_srvs/SetBool.h>
#include <std_srvs/Trigger.h>

#include "agnc_pgo/LoadGraph.h"
#include "agnc_pgo/SaveGraph.h"
#include "agnc_pgo/SaveTrajectory.h"
#include "agnc_pgo/SetLoopClosureStatus.h"

namespace agnc_pgo {
namespace panel {

template <typename Service>
CommandOutcome BackendCommands::call(const std::string& name, Service* service) const {
  const std::string full = backend_ + "/" + name;
  if (!ros::service::waitForService(full, ros::Duration(timeout_)))
    return {false, full + " is not available (is the back-end running?)"};
  if (!ros::service::call(full, *service)) return {false, full + " failed"};
  return {static_cast<bool>(service->response.success), service->response.message};
}

CommandOutcome BackendCommands::setOverride(int loop_index, int mode) const {
  agnc_pgo::SetLoopClosureStatus service;
  service.request.index = static_cast<uint32_t>(loop_index);
  service.request.mode = static_cast<uint8_t>(mode);
  return call("set_loop_closure_status", &service);
}

CommandOutcome BackendCommands::pause(bool paused) const {
  std_srvs::SetBool service;
  service.request.data = paused;
  return call("pause", &service);
}

CommandOutcome BackendCommands::optimize() const {
  std_srvs::Trigger service;
  return call("optimize", &service);
}

CommandOutcome BackendCommands::saveGraph(const std::string& filename) const {
  agnc_pgo::SaveGraph service;
  service.request.filename = filename;
  return call("save_graph", &service);
}

CommandOutcome BackendCommands::loadGraph(const std::string& filename) const {
  agnc_pgo::LoadGraph service;
  service.request.filename = filename;
  return call("load_graph", &service);
}

CommandOutcome BackendCommands::saveTrajectory(const std::string& filename) const {
  agnc_pgo::SaveTrajectory service;
  service.request.filename = filename;
  return call("save_trajectory", &service);
}

}  // namespace panel
}  // namespace agnc_pgo
