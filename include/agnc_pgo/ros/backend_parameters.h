// Parameters of the ROS back-end: read once at start-up from the private
// node handle into plain structs, validated, and logged (config/default.yaml
// documents every one of them). The runtime ones (cfg/Backend.cfg on ~,
// cfg/Gnc.cfg on ~gnc) change through dynamic_reconfigure, validated by the
// same validate(). This file and backend_parameters.cpp are the only place
// that maps ROS parameter names to these structs and to core::GncOptions.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <dynamic_reconfigure/Config.h>

#include "agnc_pgo/core/gnc_options.h"

namespace ros {
class NodeHandle;
}

namespace agnc_pgo {
namespace ros_backend {

// Six standard deviations in REP 103 order: x y z [m], roll pitch yaw [rad].
using Sigmas = std::array<double, 6>;

struct KeyframeParameters {
  double translation = 0.0;  // [m]   new keyframe after this much motion (0 = criterion off)
  double rotation = 0.0;     // [rad] ... or this much rotation (0 = off)
  double interval = 0.0;     // [s]   ... or this much time (0 = off); all off = every message
};

// Start-up only: dimension, frames, initial_graph, keyframes, the sigmas,
// use_odometry_covariance, publish_pose_graph, the marker sizes and the
// queues. Runtime (dynamic_reconfigure): paused, the rates, the tolerances
// and plausibility bounds, optimize_iterations and every gnc option
// (runtimeParameterNames()).
struct BackendParameters {
  int dimension = 2;                       // 2 (SE(2): x y yaw) or 3 (SE(3))
  std::string initial_graph;               // saved graph (~save_graph) loaded at start-up; empty: none
  std::string map_frame = "map";
  std::string odom_frame = "odom";
  KeyframeParameters keyframes;
  Sigmas odometry_sigmas{{0.05, 0.05, 0.05, 0.01, 0.01, 0.02}};
  bool use_odometry_covariance = false;    // take Odometry.pose.covariance as the motion's covariance
  Sigmas loop_closure_sigmas{{0.1, 0.1, 0.1, 0.02, 0.02, 0.05}};  // for all-zero LoopClosure.covariance
  double prior_sigma = 1e-4;               // gauge on the first keyframe (all six components)
  double stamp_tolerance = 0.005;          // [s] loop-closure stamp -> keyframe matching
  double loop_closure_hold_time = 2.0;     // [s] wait for not-yet-seen keyframes, then drop
  // Plausibility bounds: messages beyond them are rejected (ROS_WARN + counter).
  double max_position = 1e6;               // [m] |component| of an odometry position or loop-closure translation
  double max_information = 1e12;           // |entry| of an information matrix from a message covariance
  double max_odometry_jump = 100.0;        // [m] between consecutive accepted odometry messages
  core::GncOptions gnc;
  int optimize_iterations = 20;            // ~optimize service: max Gauss-Newton iterations
  double tf_rate = 20.0;                   // [Hz] map -> odom broadcast
  double tf_future_tolerance = 0.1;        // [s]  map -> odom stamps are future-dated by this
  double visualization_rate = 2.0;         // [Hz] max rate of ~markers and ~pose_graph
  double status_rate = 1.0;                // [Hz] ~status heartbeat (also after every update)
  bool publish_pose_graph = true;
  double marker_node_scale = 0.15;         // [m]
  double marker_line_width = 0.05;         // [m]
  int queue_size = 1000;                   // subscriber queues
  int max_queue = 100000;                  // worker queue bound (excess messages are rejected)
  bool paused = false;                     // start paused (as ~pause true)
};

// Throws std::invalid_argument naming the parameter and the accepted range.
void validate(const BackendParameters& p);

// Reads every parameter (defaults above when absent), then validates.
// Throws std::invalid_argument for a wrong type or an invalid value.
// `unknown` (optional) receives the names under the private namespace that
// are no parameter of the back-end (relative, e.g. "keyframe_translaton").
BackendParameters readParameters(const ros::NodeHandle& private_nh, std::vector<std::string>* unknown = nullptr);

// Multi-line human-readable dump for the start-up log.
std::string describe(const BackendParameters& p);

// ---------------------------------------------------------------- runtime (dynamic_reconfigure)
// `ns` names a reconfigure server: "" for ~ (cfg/Backend.cfg), "gnc" for
// ~gnc (cfg/Gnc.cfg). Its parameters are named as in the yaml, relative to
// the server's namespace.
extern const char* const kGncNamespace;  // "gnc"

// The runtime parameters of the server `ns` ("tf_rate", ... / "schedule", ...).
std::vector<std::string> runtimeParameterNames(const std::string& ns);

// Sets every entry of `msg` (a Config message of server `ns`, e.g. from
// BackendConfig::__toMessage__) to its value in `p`. Throws
// std::logic_error for an entry that is no runtime parameter of `ns`.
void writeRuntimeParameters(const BackendParameters& p, const std::string& ns, dynamic_reconfigure::Config* msg);

// `current` with the entries of `msg` (server `ns`) applied, then validated
// by validate(), exactly as at start-up. Throws std::invalid_argument naming
// the parameter (an unknown enum value, a value out of range); `current` is
// what stays in force then.
BackendParameters readRuntimeParameters(const BackendParameters& current, const std::string& ns,
                                        const dynamic_reconfigure::Config& msg);

// The runtime parameters that differ, "~tf_rate 20 -> 5, ~gnc/schedule agnc
// -> none" (empty: none). Only runtime parameters are compared.
std::string describeChanges(const BackendParameters& before, const BackendParameters& after);
// Whether any gnc option differs.
bool gncOptionsDiffer(const BackendParameters& a, const BackendParameters& b);

// A generated dynamic_reconfigure Config (agnc_pgo::BackendConfig for ns "",
// agnc_pgo::GncConfig for "gnc") holding the runtime parameters of `p`.
template <class Config>
Config toConfig(const BackendParameters& p, const std::string& ns) {
  Config config = Config::__getDefault__();
  dynamic_reconfigure::Config msg;
  config.__toMessage__(msg);
  writeRuntimeParameters(p, ns, &msg);
  config.__fromMessage__(msg);
  return config;
}

}  // namespace ros_backend
}  // namespace agnc_pgo
