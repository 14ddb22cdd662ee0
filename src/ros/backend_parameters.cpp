#include "agnc_pgo/ros/backend_parameters.h"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <set>
#include <vector>

#include <ros/ros.h>

namespace agnc_pgo {
namespace ros_backend {
namespace {

void require(bool ok, const std::string& name, const std::string& what) {
  if (!ok) throw std::invalid_argument("parameter ~" + name + " " + what);
}

void requirePositive(double value, const std::string& name) {
  require(std::isfinite(value) && value > 0.0, name, "must be > 0 (got " + std::to_string(value) + ")");
}

void requireNonNegative(double value, const std::string& name) {
  require(std::isfinite(value) && value >= 0.0, name, "must be >= 0 (got " + std::to_string(value) + ")");
}

// The private node handle, remembering every name asked for: what is left
// under the namespace is unknown (a typo such as keyframe_translaton).
class ParameterSource {
 public:
  explicit ParameterSource(const ros::NodeHandle& nh) : nh_(nh) {}
  bool hasParam(const std::string& name) {
    asked_.insert(name);
    return nh_.hasParam(name);
  }
  template <typename T>
  bool getParam(const std::string& name, T& value) {
    asked_.insert(name);
    return nh_.getParam(name, value);
  }
  std::vector<std::string> unknown() const {
    std::vector<std::string> names, unknown;
    ros::param::getParamNames(names);
    const std::string prefix = nh_.getNamespace() + "/";
    for (const std::string& name : names) {
      if (name.compare(0, prefix.size(), prefix) != 0) continue;
      const std::string relative = name.substr(prefix.size());
      if (!asked_.count(relative)) unknown.push_back(relative);
    }
    return unknown;
  }

 private:
  const ros::NodeHandle& nh_;
  std::set<std::string> asked_;
};

// Reads ~name if present; a present parameter of the wrong type is an error.
template <typename T>
void get(ParameterSource& nh, const std::string& name, T* value, const char* type) {
  if (!nh.hasParam(name)) return;
  if (!nh.getParam(name, *value)) throw std::invalid_argument("parameter ~" + name + " must be " + type);
}

void getDouble(ParameterSource& nh, const std::string& name, double* value) {
  if (!nh.hasParam(name)) return;
  XmlRpc::XmlRpcValue v;
  nh.getParam(name, v);
  if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble) *value = static_cast<double>(v);
  else if (v.getType() == XmlRpc::XmlRpcValue::TypeInt) *value = static_cast<int>(v);
  else throw std::invalid_argument("parameter ~" + name + " must be a number");
}

void getSigmas(ParameterSource& nh, const std::string& name, Sigmas* sigmas) {
  if (!nh.hasParam(name)) return;
  XmlRpc::XmlRpcValue v;
  nh.getParam(name, v);
  if (v.getType() != XmlRpc::XmlRpcValue::TypeArray || v.size() != 6)
    throw std::invalid_argument("parameter ~" + name +
                                " must be a list of 6 numbers (x y z roll pitch yaw standard deviations)");
  for (int i = 0; i < 6; ++i) {
    if (v[i].getType() == XmlRpc::XmlRpcValue::TypeDouble) (*sigmas)[i] = static_cast<double>(v[i]);
    else if (v[i].getType() == XmlRpc::XmlRpcValue::TypeInt) (*sigmas)[i] = static_cast<int>(v[i]);
    else throw std::invalid_argument("parameter ~" + name + "[" + std::to_string(i) + "] must be a number");
  }
}

std::string list(const Sigmas& s) {
  std::ostringstream out;
  out << "[" << s[0] << ", " << s[1] << ", " << s[2] << ", " << s[3] << ", " << s[4] << ", " << s[5] << "]";
  return out.str();
}

}  // namespace

void validate(const BackendParameters& p) {
  require(p.dimension == 2 || p.dimension == 3, "dimension", "must be 2 or 3 (got " + std::to_string(p.dimension) + ")");
  require(!p.map_frame.empty(), "map_frame", "must not be empty");
  require(!p.odom_frame.empty(), "odom_frame", "must not be empty");
  require(p.map_frame != p.odom_frame, "map_frame", "must differ from ~odom_frame");
  requireNonNegative(p.keyframes.translation, "keyframe_translation");
  requireNonNegative(p.keyframes.rotation, "keyframe_rotation");
  requireNonNegative(p.keyframes.interval, "keyframe_interval");
  for (int i = 0; i < 6; ++i) {
    requirePositive(p.odometry_sigmas[i], "odometry_sigmas[" + std::to_string(i) + "]");
    requirePositive(p.loop_closure_sigmas[i], "loop_closure_sigmas[" + std::to_string(i) + "]");
  }
  requirePositive(p.prior_sigma, "prior_sigma");
  requireNonNegative(p.stamp_tolerance, "stamp_tolerance");
  requireNonNegative(p.loop_closure_hold_time, "loop_closure_hold_time");
  requirePositive(p.max_position, "max_position");
  require(p.max_position <= 1e9, "max_position", "must be <= 1e9 (the file readers' bound)");
  requirePositive(p.max_information, "max_information");
  require(p.max_information <= 1e15, "max_information", "must be <= 1e15 (the file readers' bound)");
  requirePositive(p.max_odometry_jump, "max_odometry_jump");
  require(p.optimize_iterations >= 1, "optimize_iterations", "must be >= 1");
  requirePositive(p.tf_rate, "tf_rate");
  requireNonNegative(p.tf_future_tolerance, "tf_future_tolerance");
  requirePositive(p.visualization_rate, "visualization_rate");
  requirePositive(p.status_rate, "status_rate");
  requirePositive(p.marker_node_scale, "marker_node_scale");
  requirePositive(p.marker_line_width, "marker_line_width");
  require(p.queue_size >= 1, "queue_size", "must be >= 1");
  require(p.max_queue >= 1, "max_queue", "must be >= 1");
  try {
    core::validate(p.gnc);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("GNC parameters: ") + e.what());
  }
}

BackendParameters readParameters(const ros::NodeHandle& private_nh, std::vector<std::string>* unknown) {
  ParameterSource nh(private_nh);
  BackendParameters p;
  get(nh, "dimension", &p.dimension, "an integer (2 or 3)");
  get(nh, "initial_graph", &p.initial_graph, "a string (a file written by ~save_graph)");
  get(nh, "map_frame", &p.map_frame, "a string");
  get(nh, "odom_frame", &p.odom_frame, "a string");
  getDouble(nh, "keyframe_translation", &p.keyframes.translation);
  getDouble(nh, "keyframe_rotation", &p.keyframes.rotation);
  getDouble(nh, "keyframe_interval", &p.keyframes.interval);
  getSigmas(nh, "odometry_sigmas", &p.odometry_sigmas);
  get(nh, "use_odometry_covariance", &p.use_odometry_covariance, "a bool");
  getSigmas(nh, "loop_closure_sigmas", &p.loop_closure_sigmas);
  getDouble(nh, "prior_sigma", &p.prior_sigma);
  getDouble(nh, "stamp_tolerance", &p.stamp_tolerance);
  getDouble(nh, "loop_closure_hold_time", &p.loop_closure_hold_time);
  getDouble(nh, "max_position", &p.max_position);
  getDouble(nh, "max_information", &p.max_information);
  getDouble(nh, "max_odometry_jump", &p.max_odometry_jump);

  std::string text;
  try {
    if (nh.hasParam("gnc/schedule")) {
      get(nh, "gnc/schedule", &text, "a string");
      p.gnc.schedule = core::parseSchedule(text);
    }
    if (nh.hasParam("gnc/distance")) {
      get(nh, "gnc/distance", &text, "a string");
      p.gnc.distance = core::parseDistanceConvention(text);
    }
    if (nh.hasParam("gnc/reset")) {
      get(nh, "gnc/reset", &text, "a string");
      p.gnc.reset = core::parseResetPolicy(text);
    }
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("parameter ~gnc/...: ") + e.what());
  }
  getDouble(nh, "gnc/shape_c", &p.gnc.shape_c);
  getDouble(nh, "gnc/fixed_alpha", &p.gnc.fixed_alpha);
  get(nh, "gnc/reference_alpha_direction", &p.gnc.reference_alpha_direction, "a bool");
  get(nh, "gnc/max_settle_iterations", &p.gnc.max_settle_iterations, "an integer");
  getDouble(nh, "gnc/convergence_step", &p.gnc.convergence_step);
  get(nh, "gnc/adapt_initial_mu", &p.gnc.adapt_initial_mu, "a bool");
  get(nh, "gnc/local_window", &p.gnc.local_window, "a bool");
  get(nh, "gnc/max_window_poses", &p.gnc.max_window_poses, "an integer");
  get(nh, "gnc/max_gnc_steps", &p.gnc.max_gnc_steps, "an integer");
  get(nh, "gnc/global_refinement", &p.gnc.global_refinement, "a bool");
  get(nh, "gnc/max_iterations_per_step", &p.gnc.max_iterations_per_step, "an integer");
  get(nh, "gnc/trust_region", &p.gnc.trust_region, "a bool");
  getDouble(nh, "gnc/trust_region_radius", &p.gnc.trust_region_radius);
  getDouble(nh, "gnc/max_trust_region_radius", &p.gnc.max_trust_region_radius);
  getDouble(nh, "gnc/dormant_weight", &p.gnc.dormant_weight);
  get(nh, "gnc/support_radius", &p.gnc.support_radius, "an integer");
  get(nh, "optimize_iterations", &p.optimize_iterations, "an integer");

  getDouble(nh, "tf_rate", &p.tf_rate);
  getDouble(nh, "tf_future_tolerance", &p.tf_future_tolerance);
  getDouble(nh, "visualization_rate", &p.visualization_rate);
  getDouble(nh, "status_rate", &p.status_rate);
  get(nh, "publish_pose_graph", &p.publish_pose_graph, "a bool");
  getDouble(nh, "marker_node_scale", &p.marker_node_scale);
  getDouble(nh, "marker_line_width", &p.marker_line_width);
  get(nh, "queue_size", &p.queue_size, "an integer");
  get(nh, "max_queue", &p.max_queue, "an integer");
  validate(p);
  if (unknown) *unknown = nh.unknown();
  return p;
}

std::string describe(const BackendParameters& p) {
  std::ostringstream out;
  out << "agnc_pgo back-end parameters:\n"
      << "  dimension: " << p.dimension << ", frames: " << p.map_frame << " -> " << p.odom_frame << "\n"
      << "  keyframes: translation " << p.keyframes.translation << " m, rotation " << p.keyframes.rotation
      << " rad, interval " << p.keyframes.interval << " s\n"
      << "  odometry_sigmas " << list(p.odometry_sigmas)
      << (p.use_odometry_covariance ? " (messages' covariance used)" : "") << "\n"
      << "  loop_closure_sigmas " << list(p.loop_closure_sigmas) << ", prior_sigma " << p.prior_sigma << "\n"
      << "  stamp_tolerance " << p.stamp_tolerance << " s, loop_closure_hold_time " << p.loop_closure_hold_time
      << " s\n"
      << "  plausibility: max_position " << p.max_position << " m, max_information " << p.max_information
      << ", max_odometry_jump " << p.max_odometry_jump << " m\n"
      << "  gnc: schedule " << core::toString(p.gnc.schedule) << ", distance "
      << core::toString(p.gnc.distance) << ", reset " << core::toString(p.gnc.reset) << ", shape_c "
      << p.gnc.shape_c << ", local_window " << (p.gnc.local_window ? "true" : "false")
      << " (at most " << p.gnc.max_window_poses << " poses, 0: unbounded)"
      << ", global_refinement " << (p.gnc.global_refinement ? "true" : "false")
      << ", trust_region " << (p.gnc.trust_region ? "true" : "false") << " (radius "
      << p.gnc.trust_region_radius << " per update, max " << p.gnc.max_trust_region_radius << ")"
      << ", max_iterations_per_step " << p.gnc.max_iterations_per_step << ", dormant_weight "
      << p.gnc.dormant_weight << ", support_radius " << p.gnc.support_radius << " poses, max_settle_iterations " << p.gnc.max_settle_iterations << ", convergence_step "
      << p.gnc.convergence_step << ", max_gnc_steps " << p.gnc.max_gnc_steps << "\n"
      << "  tf_rate " << p.tf_rate << " Hz (future-dated " << p.tf_future_tolerance << " s), visualization_rate "
      << p.visualization_rate << " Hz, status_rate " << p.status_rate << " Hz, publish_pose_graph "
      << (p.publish_pose_graph ? "true" : "false")
      << (p.initial_graph.empty() ? std::string() : "\n  initial_graph " + p.initial_graph);
  return out.str();
}

}  // namespace ros_backend
}  // namespace agnc_pgo
