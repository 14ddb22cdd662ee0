// agnc_pgo/BackendNodelet: wiring of topics, services and timers to the worker.
#include "agnc_pgo/ros/backend_nodelet.h"

#include <cmath>
#include <stdexcept>

#include <geometry_msgs/TransformStamped.h>
#include <pluginlib/class_list_macros.hpp>

#include "agnc_pgo/ros/conversions.h"

namespace agnc_pgo {
namespace ros_backend {

BackendNodelet::~BackendNodelet() {
  tf_timer_.stop();
  backend_server_.reset();
  gnc_server_.reset();
  if (worker_) worker_->stop();
}

// A start-up that fails must not leave a ROS handle behind: nodelet 1.10
// (Debian 12), on an exception from onInit(), frees this nodelet's callback
// queues and only then the nodelet, and a publisher, subscriber, service or
// timer destroyed after its queue calls removeByID() on the freed queue
// (fixed upstream in nodelet 1.11, ros/nodelet_core#122). So they are all
// shut down here, while the queues are alive, before the exception goes on.
void BackendNodelet::onInit() {
  try {
    start();
  } catch (...) {
    shutdownHandles();
    throw;
  }
}

void BackendNodelet::shutdownHandles() {
  tf_timer_.stop();
  tf_timer_ = ros::WallTimer();
  if (worker_) worker_->stop();  // it publishes: stopped before the publishers go
  for (ros::ServiceServer& service : services_) service.shutdown();
  services_.clear();
  odometry_subscriber_.shutdown();
  loop_closure_subscriber_.shutdown();
  for (ros::Publisher* publisher : {&path_publisher_, &marker_publisher_, &pose_graph_publisher_,
                                    &status_publisher_, &keyframe_publisher_})
    publisher->shutdown();
  broadcaster_.reset();
}

void BackendNodelet::start() {
  readAndLogParameters();
  advertiseOutputs();
  startWorker();
  connectInputs();
  startReconfigureServers();
}

void BackendNodelet::readAndLogParameters() {
  ros::NodeHandle& pnh = getPrivateNodeHandle();
  std::vector<std::string> unknown;
  try {
    parameters_ = readParameters(pnh, &unknown);
  } catch (const std::exception& e) {
    NODELET_FATAL_STREAM("agnc_pgo: invalid parameters, not starting: " << e.what());
    throw std::runtime_error(std::string("agnc_pgo: invalid parameters: ") + e.what());
  }
  current_ = parameters_;
  NODELET_INFO_STREAM(describe(parameters_));
  for (const std::string& name : unknown)
    NODELET_WARN_STREAM("agnc_pgo: unknown parameter ~" << name << " (ignored; misspelt? see config/default.yaml)");
  style_.frame = parameters_.map_frame;
  style_.node_scale = parameters_.marker_node_scale;
  style_.line_width = parameters_.marker_line_width;
}

void BackendNodelet::advertiseOutputs() {
  ros::NodeHandle& pnh = getPrivateNodeHandle();
  path_publisher_ = pnh.advertise<nav_msgs::Path>("path", 1, /*latch=*/true);
  marker_publisher_ = pnh.advertise<visualization_msgs::MarkerArray>("markers", 1, true);
  if (parameters_.publish_pose_graph)
    pose_graph_publisher_ = pnh.advertise<agnc_pgo::PoseGraph>("pose_graph", 1, true);
  status_publisher_ = pnh.advertise<agnc_pgo::GraphStatus>("status", 10, true);
  keyframe_publisher_ = pnh.advertise<agnc_pgo::Keyframe>("keyframes", 100);
  broadcaster_ = std::make_unique<tf2_ros::TransformBroadcaster>();
}

void BackendNodelet::startWorker() {
  worker_ = std::make_unique<BackendWorker>(parameters_, this);
  worker_->start();
  if (parameters_.initial_graph.empty()) return;
  const CommandResult loaded = worker_->loadGraph(parameters_.initial_graph);
  if (!loaded.success) {
    NODELET_FATAL_STREAM("agnc_pgo: ~initial_graph: " << loaded.message << ", not starting");
    throw std::runtime_error("agnc_pgo: ~initial_graph: " + loaded.message);
  }
  NODELET_INFO_STREAM("agnc_pgo: ~initial_graph: " << loaded.message);
}

void BackendNodelet::connectInputs() {
  ros::NodeHandle& pnh = getPrivateNodeHandle();
  odometry_subscriber_ = pnh.subscribe("odom", parameters_.queue_size, &BackendNodelet::odometryCallback, this,
                                       ros::TransportHints().tcpNoDelay());
  loop_closure_subscriber_ = pnh.subscribe("loop_closures", parameters_.queue_size,
                                           &BackendNodelet::loopClosureCallback, this,
                                           ros::TransportHints().tcpNoDelay());
  // Services on the multi-threaded handle: they wait for the worker, the
  // subscriptions and the tf timer must not.
  ros::NodeHandle& mt = getMTPrivateNodeHandle();
  services_.push_back(mt.advertiseService("save_graph", &BackendNodelet::saveGraph, this));
  services_.push_back(mt.advertiseService("load_graph", &BackendNodelet::loadGraph, this));
  services_.push_back(mt.advertiseService("save_trajectory", &BackendNodelet::saveTrajectory, this));
  services_.push_back(mt.advertiseService("optimize", &BackendNodelet::optimize, this));
  services_.push_back(mt.advertiseService("reset", &BackendNodelet::reset, this));
  services_.push_back(mt.advertiseService("pause", &BackendNodelet::pause, this));
  services_.push_back(
      mt.advertiseService("set_loop_closure_status", &BackendNodelet::setLoopClosureStatus, this));
  tf_timer_ = pnh.createWallTimer(ros::WallDuration(1.0 / parameters_.tf_rate), &BackendNodelet::tfTimerCallback,
                                  this);
}

void BackendNodelet::startReconfigureServers() {
  // Runtime parameters: the servers start from the validated start-up values
  // (not the .cfg defaults), then take requests on this node's queue.
  ros::NodeHandle& pnh = getPrivateNodeHandle();
  boost::recursive_mutex::scoped_lock lock(reconfigure_mutex_);
  backend_server_ = std::make_unique<dynamic_reconfigure::Server<agnc_pgo::BackendConfig>>(reconfigure_mutex_, pnh);
  backend_server_->updateConfig(toConfig<agnc_pgo::BackendConfig>(current_, ""));
  backend_server_->setCallback(
      [this](agnc_pgo::BackendConfig& config, uint32_t) { reconfigure(config, ""); });
  gnc_server_ = std::make_unique<dynamic_reconfigure::Server<agnc_pgo::GncConfig>>(
      reconfigure_mutex_, ros::NodeHandle(pnh, kGncNamespace));
  gnc_server_->updateConfig(toConfig<agnc_pgo::GncConfig>(current_, kGncNamespace));
  gnc_server_->setCallback(
      [this](agnc_pgo::GncConfig& config, uint32_t) { reconfigure(config, kGncNamespace); });
}

template <class Config>
void BackendNodelet::reconfigure(Config& config, const std::string& ns) {
  boost::recursive_mutex::scoped_lock lock(reconfigure_mutex_);
  dynamic_reconfigure::Config request;
  config.__toMessage__(request);
  BackendParameters next;
  try {
    next = readRuntimeParameters(current_, ns, request);
  } catch (const std::exception& e) {
    NODELET_WARN_STREAM("agnc_pgo: dynamic_reconfigure request refused, previous values kept: " << e.what());
    config = toConfig<Config>(current_, ns);
    return;
  }
  if (describeChanges(current_, next).empty()) return;
  if (next.tf_rate != current_.tf_rate) tf_timer_.setPeriod(ros::WallDuration(1.0 / next.tf_rate));
  current_ = next;
  worker_->reconfigure(next);  // logged when applied
}

// ---------------------------------------------------------------- callbacks: validate + enqueue

void BackendNodelet::odometryCallback(const nav_msgs::Odometry::ConstPtr& message) {
  try {
    const std::string bad_pose = checkPose(message->pose.pose);
    if (!bad_pose.empty()) return worker_->rejectOdometry(bad_pose);
    const std::string bad_position = checkPosition(message->pose.pose, current_.max_position);
    if (!bad_position.empty()) return worker_->rejectOdometry(bad_position);
    if (message->header.stamp.isZero()) return worker_->rejectOdometry("zero stamp");
    if (!warned_frame_ && !message->header.frame_id.empty() && message->header.frame_id != parameters_.odom_frame) {
      warned_frame_ = true;
      NODELET_WARN_STREAM("agnc_pgo: odometry frame '" << message->header.frame_id << "' differs from ~odom_frame '"
                                                        << parameters_.odom_frame << "' (using it as " << parameters_.odom_frame << ")");
    }
    OdometryInput input;
    input.stamp = message->header.stamp;
    input.pose = toDimension(fromMsg(message->pose.pose), parameters_.dimension);
    if (parameters_.use_odometry_covariance) {
      if (isZero(message->pose.covariance))
        return worker_->rejectOdometry("zero covariance with ~use_odometry_covariance");
      input.information = informationFromCovariance(message->pose.covariance, parameters_.dimension);
      const std::string bad_information = checkInformation(input.information, current_.max_information);
      if (!bad_information.empty()) return worker_->rejectOdometry(bad_information);
    }
    worker_->enqueueOdometry(input);
  } catch (const std::exception& e) {
    worker_->rejectOdometry(e.what());
  }
}

void BackendNodelet::loopClosureCallback(const agnc_pgo::LoopClosure::ConstPtr& message) {
  const double received = BackendWorker::now();
  try {
    const std::string bad_pose = checkPose(message->relative_pose);
    if (!bad_pose.empty()) return worker_->rejectLoopClosure(bad_pose);
    const std::string bad_position = checkPosition(message->relative_pose, current_.max_position);
    if (!bad_position.empty()) return worker_->rejectLoopClosure(bad_position);
    // The score is stored in saved graphs; NaN there would make them unloadable.
    if (!std::isfinite(message->score)) return worker_->rejectLoopClosure("score is NaN/Inf");
    if (message->from_stamp.isZero() || message->to_stamp.isZero())
      return worker_->rejectLoopClosure("zero from_stamp/to_stamp");
    LoopClosureInput input;
    input.from_stamp = message->from_stamp;
    input.to_stamp = message->to_stamp;
    input.measurement = toDimension(fromMsg(message->relative_pose), parameters_.dimension);
    if (!isZero(message->covariance)) {
      input.information = informationFromCovariance(message->covariance, parameters_.dimension);
      const std::string bad_information = checkInformation(input.information, current_.max_information);
      if (!bad_information.empty()) return worker_->rejectLoopClosure(bad_information);
    }
    input.source = message->source;
    input.score = message->score;
    input.received = received;
    worker_->enqueueLoopClosure(input);
  } catch (const std::exception& e) {
    worker_->rejectLoopClosure(e.what());
  }
}

void BackendNodelet::tfTimerCallback(const ros::WallTimerEvent&) {
  const ros::Time stamp = ros::Time::now() + ros::Duration(current_.tf_future_tolerance);
  if (stamp <= last_tf_stamp_) return;  // never repeat a stamp (sim time paused, clock jumps)
  last_tf_stamp_ = stamp;
  const core::Pose m = worker_->mapToOdom();
  geometry_msgs::TransformStamped t;
  t.header.stamp = stamp;
  t.header.frame_id = parameters_.map_frame;
  t.child_frame_id = parameters_.odom_frame;
  t.transform.translation.x = m.translation.x();
  t.transform.translation.y = m.translation.y();
  t.transform.translation.z = m.translation.z();
  t.transform.rotation.x = m.rotation.x();
  t.transform.rotation.y = m.rotation.y();
  t.transform.rotation.z = m.rotation.z();
  t.transform.rotation.w = m.rotation.w();
  broadcaster_->sendTransform(t);
}

// ---------------------------------------------------------------- publishing (worker thread)

void BackendNodelet::publishEstimate(const GraphSnapshot& snapshot) {
  path_publisher_.publish(makePath(snapshot, parameters_.map_frame));
}

void BackendNodelet::publishGraph(const GraphSnapshot& snapshot) {
  marker_publisher_.publish(makeMarkers(snapshot, style_));
  if (pose_graph_publisher_) pose_graph_publisher_.publish(makePoseGraph(snapshot, parameters_.map_frame));
}

void BackendNodelet::publishStatus(const StatusInfo& status) { status_publisher_.publish(makeStatus(status)); }

void BackendNodelet::publishKeyframe(int id, const ros::Time& stamp, const core::Pose& estimate) {
  agnc_pgo::Keyframe keyframe;
  keyframe.header.stamp = stamp;
  keyframe.header.frame_id = parameters_.map_frame;
  keyframe.id = static_cast<uint32_t>(id);
  keyframe.pose = toMsg(estimate);
  keyframe_publisher_.publish(keyframe);
}

// ---------------------------------------------------------------- services

namespace {
template <typename Response>
bool respond(const CommandResult& result, Response* response) {
  response->success = result.success;
  response->message = result.message;
  if (result.success) ROS_INFO_STREAM("agnc_pgo: " << result.message);
  else ROS_WARN_STREAM("agnc_pgo: " << result.message);
  return true;
}
}  // namespace

bool BackendNodelet::saveGraph(agnc_pgo::SaveGraph::Request& req, agnc_pgo::SaveGraph::Response& res) {
  return respond(worker_->saveGraph(req.filename), &res);
}
bool BackendNodelet::loadGraph(agnc_pgo::LoadGraph::Request& req, agnc_pgo::LoadGraph::Response& res) {
  return respond(worker_->loadGraph(req.filename), &res);
}
bool BackendNodelet::saveTrajectory(agnc_pgo::SaveTrajectory::Request& req,
                                    agnc_pgo::SaveTrajectory::Response& res) {
  return respond(worker_->saveTrajectory(req.filename), &res);
}
bool BackendNodelet::optimize(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  return respond(worker_->optimize(), &res);
}
bool BackendNodelet::reset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  return respond(worker_->reset(), &res);
}
bool BackendNodelet::pause(std_srvs::SetBool::Request& req, std_srvs::SetBool::Response& res) {
  {
    // The reconfigure server shows what is in force, from before ~status does.
    boost::recursive_mutex::scoped_lock lock(reconfigure_mutex_);
    current_.paused = req.data;
    if (backend_server_) backend_server_->updateConfig(toConfig<agnc_pgo::BackendConfig>(current_, ""));
  }
  respond(worker_->setPaused(req.data), &res);
  return true;
}
bool BackendNodelet::setLoopClosureStatus(agnc_pgo::SetLoopClosureStatus::Request& req,
                                          agnc_pgo::SetLoopClosureStatus::Response& res) {
  if (req.mode > agnc_pgo::SetLoopClosureStatus::Request::FORCE_OUTLIER) {
    res.success = false;
    res.message = "mode must be 0 (auto), 1 (force inlier) or 2 (force outlier)";
    return true;
  }
  const auto mode = static_cast<core::LoopOverride>(req.mode);
  if (!req.from_stamp.isZero() && !req.to_stamp.isZero())
    return respond(worker_->setLoopClosureStatus(req.from_stamp, req.to_stamp, mode), &res);
  return respond(worker_->setLoopClosureStatus(static_cast<int>(req.index), mode), &res);
}

}  // namespace ros_backend
}  // namespace agnc_pgo

PLUGINLIB_EXPORT_CLASS(agnc_pgo::ros_backend::BackendNodelet, nodelet::Nodelet)
