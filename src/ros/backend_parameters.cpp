#include "agnc_pgo/ros/backend_parameters.h"

#include <algorithm>
#include <cmath>
#include <type_traits>
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

// ---------------------------------------------------------------- the runtime parameters, once
// Every runtime parameter with its ROS name: readParameters(), the
// dynamic_reconfigure mapping, describe() and describeChanges() all go
// through these two lists. `P` is BackendParameters or const BackendParameters.

// ~NAME (cfg/Backend.cfg).
template <class P, class F>
void forEachBackendRuntimeParameter(P& p, F&& f) {
  f("paused", p.paused);
  f("tf_rate", p.tf_rate);
  f("tf_future_tolerance", p.tf_future_tolerance);
  f("visualization_rate", p.visualization_rate);
  f("status_rate", p.status_rate);
  f("stamp_tolerance", p.stamp_tolerance);
  f("loop_closure_hold_time", p.loop_closure_hold_time);
  f("max_position", p.max_position);
  f("max_information", p.max_information);
  f("max_odometry_jump", p.max_odometry_jump);
  f("optimize_iterations", p.optimize_iterations);
}

// ~gnc/NAME (cfg/Gnc.cfg): the core engine's options.
template <class O, class F>
void forEachGncOption(O& o, F&& f) {
  f("schedule", o.schedule.kind);
  f("distance", o.schedule.distance);
  f("classification", o.schedule.classification);
  f("reset", o.schedule.reset);
  f("shape_c", o.schedule.shape_c);
  f("fixed_alpha", o.schedule.fixed_alpha);
  f("reference_alpha_direction", o.schedule.reference_alpha_direction);
  f("max_settle_iterations", o.solver.max_settle_iterations);
  f("convergence_step", o.solver.convergence_step);
  f("adapt_initial_mu", o.schedule.adapt_initial_mu);
  f("local_window", o.window.local);
  f("max_window_poses", o.window.max_poses);
  f("global_refinement", o.window.global_refinement);
  f("max_iterations_per_step", o.solver.max_iterations_per_step);
  f("trust_region", o.solver.trust_region);
  f("trust_region_radius", o.solver.trust_region_radius);
  f("max_trust_region_radius", o.solver.max_trust_region_radius);
  f("dormant_weight", o.rejection.dormant_weight);
  f("support_radius", o.rejection.support_radius);
  f("max_gnc_steps", o.schedule.max_gnc_steps);
}

template <class P, class F>
void forEachRuntimeParameter(P& p, const std::string& ns, F&& f) {
  if (ns.empty()) forEachBackendRuntimeParameter(p, f);
  else if (ns == kGncNamespace) forEachGncOption(p.gnc, f);
  else throw std::logic_error("no reconfigure server ~" + ns);
}

// The enums as text (yaml strings, dynamic_reconfigure str_t).
std::string text(core::ScheduleKind v) { return core::toString(v); }
std::string text(core::DistanceConvention v) { return core::toString(v); }
std::string text(core::ResetPolicy v) { return core::toString(v); }
std::string text(core::Classification v) { return core::toString(v); }
std::string text(bool v) { return v ? "true" : "false"; }
std::string text(int v) { return std::to_string(v); }
std::string text(double v) {
  std::ostringstream out;
  out.precision(12);  // enough to see any change a person makes, 0.1 stays "0.1"
  out << v;
  return out.str();
}
void parse(const std::string& t, core::ScheduleKind* v) { *v = core::parseSchedule(t); }
void parse(const std::string& t, core::DistanceConvention* v) { *v = core::parseDistanceConvention(t); }
void parse(const std::string& t, core::ResetPolicy* v) { *v = core::parseResetPolicy(t); }
void parse(const std::string& t, core::Classification* v) { *v = core::parseClassification(t); }

// An enum from its text; a bad one names the parameter.
template <class E>
void parseNamed(const std::string& name, const std::string& t, E* v) {
  try {
    parse(t, v);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("parameter ~" + name + ": " + e.what());
  }
}

// Reads the parameters of a list from the parameter server (~prefix + name).
struct ServerReader {
  ParameterSource& nh;
  std::string prefix;
  void operator()(const char* name, double& v) { getDouble(nh, prefix + name, &v); }
  void operator()(const char* name, int& v) { get(nh, prefix + name, &v, "an integer"); }
  void operator()(const char* name, bool& v) { get(nh, prefix + name, &v, "a bool"); }
  template <class E, typename std::enable_if<std::is_enum<E>::value, int>::type = 0>
  void operator()(const char* name, E& v) {
    if (!nh.hasParam(prefix + name)) return;
    std::string t;
    get(nh, prefix + name, &t, "a string");
    parseNamed(prefix + name, t, &v);
  }
};

// dynamic_reconfigure Config message entries: find by name.
template <class Entry, class T>
bool findEntry(const std::vector<Entry>& entries, const std::string& name, T* value) {
  for (const Entry& e : entries)
    if (e.name == name) {
      *value = e.value;
      return true;
    }
  return false;
}
template <class Entry, class T>
bool setEntry(std::vector<Entry>* entries, const std::string& name, const T& value) {
  for (Entry& e : *entries)
    if (e.name == name) {
      e.value = value;
      return true;
    }
  return false;
}

// Applies a Config message's entries to the fields of a list.
struct MessageReader {
  const dynamic_reconfigure::Config& msg;
  std::string prefix;  // for messages: "gnc/"
  void operator()(const char* name, double& v) { findEntry(msg.doubles, name, &v); }
  void operator()(const char* name, int& v) { findEntry(msg.ints, name, &v); }
  void operator()(const char* name, bool& v) { findEntry(msg.bools, name, &v); }
  template <class E, typename std::enable_if<std::is_enum<E>::value, int>::type = 0>
  void operator()(const char* name, E& v) {
    std::string t;
    if (findEntry(msg.strs, name, &t)) parseNamed(prefix + name, t, &v);
  }
};

// Writes the fields of a list into a Config message's entries; counts them.
struct MessageWriter {
  dynamic_reconfigure::Config* msg;
  int written = 0;
  void operator()(const char* name, double v) { written += setEntry(&msg->doubles, name, v); }
  void operator()(const char* name, int v) { written += setEntry(&msg->ints, name, v); }
  void operator()(const char* name, bool v) { written += setEntry(&msg->bools, name, static_cast<uint8_t>(v)); }
  template <class E, typename std::enable_if<std::is_enum<E>::value, int>::type = 0>
  void operator()(const char* name, E v) { written += setEntry(&msg->strs, name, text(v)); }
};

// "name value" for the log / "~name before -> after" for changes.
struct Describer {
  std::ostringstream* out;
  bool first = true;
  template <class T>
  void operator()(const char* name, const T& v) {
    *out << (first ? "" : ", ") << name << " " << text(v);
    first = false;
  }
};

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
    // core::validate's messages start with the field's name.
    throw std::invalid_argument("parameter ~" + std::string(kGncNamespace) + "/" + e.what());
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
  forEachBackendRuntimeParameter(p, ServerReader{nh, ""});
  forEachGncOption(p.gnc, ServerReader{nh, std::string(kGncNamespace) + "/"});
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
      << "  publish_pose_graph " << (p.publish_pose_graph ? "true" : "false") << ", marker_node_scale "
      << p.marker_node_scale << " m, marker_line_width " << p.marker_line_width << " m, queue_size "
      << p.queue_size << ", max_queue " << p.max_queue << "\n";
  Describer runtime{&out};
  out << "  runtime (dynamic_reconfigure ~): ";
  forEachBackendRuntimeParameter(p, runtime);
  Describer gnc{&out};
  out << "\n  runtime (dynamic_reconfigure ~gnc): ";
  forEachGncOption(p.gnc, gnc);
  out      << (p.initial_graph.empty() ? std::string() : "\n  initial_graph " + p.initial_graph);
  return out.str();
}

// ---------------------------------------------------------------- runtime (dynamic_reconfigure)

const char* const kGncNamespace = "gnc";

std::vector<std::string> runtimeParameterNames(const std::string& ns) {
  std::vector<std::string> names;
  const BackendParameters p;
  forEachRuntimeParameter(p, ns, [&names](const char* name, const auto&) { names.push_back(name); });
  return names;
}

void writeRuntimeParameters(const BackendParameters& p, const std::string& ns, dynamic_reconfigure::Config* msg) {
  MessageWriter writer{msg};
  forEachRuntimeParameter(p, ns, writer);
  const int entries = static_cast<int>(msg->bools.size() + msg->ints.size() + msg->doubles.size() + msg->strs.size());
  if (writer.written != entries) {
    // An entry of the server that no runtime parameter maps: cfg and lists disagree.
    std::string names;
    const std::vector<std::string> known = runtimeParameterNames(ns);
    const auto check = [&](const std::string& name) {
      if (std::find(known.begin(), known.end(), name) == known.end()) names += " " + name;
    };
    for (const auto& e : msg->bools) check(e.name);
    for (const auto& e : msg->ints) check(e.name);
    for (const auto& e : msg->doubles) check(e.name);
    for (const auto& e : msg->strs) check(e.name);
    throw std::logic_error("reconfigure server ~" + ns + ": no runtime parameter for" + names);
  }
}

BackendParameters readRuntimeParameters(const BackendParameters& current, const std::string& ns,
                                        const dynamic_reconfigure::Config& msg) {
  BackendParameters next = current;
  forEachRuntimeParameter(next, ns, MessageReader{msg, ns.empty() ? std::string() : ns + "/"});
  validate(next);
  return next;
}

std::string describeChanges(const BackendParameters& before, const BackendParameters& after) {
  std::vector<std::string> changes;
  for (const std::string& ns : {std::string(), std::string(kGncNamespace)}) {
    std::vector<std::string> old_values;
    forEachRuntimeParameter(before, ns, [&](const char*, const auto& v) { old_values.push_back(text(v)); });
    size_t i = 0;
    forEachRuntimeParameter(after, ns, [&](const char* name, const auto& v) {
      const std::string now = text(v);
      if (now != old_values[i])
        changes.push_back("~" + (ns.empty() ? std::string() : ns + "/") + name + " " + old_values[i] + " -> " + now);
      ++i;
    });
  }
  std::string out;
  for (const std::string& c : changes) out += (out.empty() ? "" : ", ") + c;
  return out;
}

bool gncOptionsDiffer(const BackendParameters& a, const BackendParameters& b) {
  BackendParameters only_gnc = a;
  only_gnc.gnc = b.gnc;
  return !describeChanges(a, only_gnc).empty();
}

}  // namespace ros_backend
}  // namespace agnc_pgo
