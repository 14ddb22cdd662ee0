// agnc_pgo/BackendNodelet: wiring only. Reads the parameters, creates the
// worker, subscribes ~odom and ~loop_closures (validate + enqueue), offers
// the services, and publishes what the worker hands over plus map -> odom
// on a timer.
#pragma once

#include <memory>
#include <mutex>

#include <boost/thread/recursive_mutex.hpp>
#include <dynamic_reconfigure/server.h>

#include <nav_msgs/Odometry.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <std_srvs/SetBool.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/transform_broadcaster.h>

#include "agnc_pgo/BackendConfig.h"
#include "agnc_pgo/GncConfig.h"
#include "agnc_pgo/Keyframe.h"
#include "agnc_pgo/LoadGraph.h"
#include "agnc_pgo/LoopClosure.h"
#include "agnc_pgo/SaveGraph.h"
#include "agnc_pgo/SaveTrajectory.h"
#include "agnc_pgo/SetLoopClosureStatus.h"
#include "agnc_pgo/ros/backend_parameters.h"
#include "agnc_pgo/ros/backend_worker.h"
#include "agnc_pgo/ros/graph_visualizer.h"

namespace agnc_pgo {
namespace ros_backend {

class BackendNodelet : public nodelet::Nodelet, public BackendOutput {
 public:
  BackendNodelet() = default;
  ~BackendNodelet() override;

  void publishEstimate(const GraphSnapshot& nodes_only) override;
  void publishGraph(const GraphSnapshot& full) override;
  void publishStatus(const StatusInfo& status) override;
  void publishKeyframe(int id, const ros::Time& stamp, const core::Pose& estimate) override;

 private:
  void onInit() override;
  void start();            // onInit's work; throws if the back-end cannot start
  // start()'s steps, in order: parameters (validated, logged), publishers,
  // the worker (and ~initial_graph), subscriptions, services and the tf
  // timer, then the dynamic_reconfigure servers.
  void readAndLogParameters();
  void advertiseOutputs();
  void startWorker();
  void connectInputs();
  void startReconfigureServers();
  void shutdownHandles();  // stops the worker, releases every ROS handle

  void odometryCallback(const nav_msgs::Odometry::ConstPtr& message);
  void loopClosureCallback(const agnc_pgo::LoopClosure::ConstPtr& message);
  void tfTimerCallback(const ros::WallTimerEvent& event);
  // dynamic_reconfigure (the node's callback queue): validates the request
  // like the start-up parameters, refuses an invalid one (ROS_WARN naming the
  // parameter; `config` is set back to the values in force), applies what
  // the callbacks and the tf timer read and hands the rest to the worker.
  template <class Config>
  void reconfigure(Config& config, const std::string& ns);

  bool saveGraph(agnc_pgo::SaveGraph::Request& request, agnc_pgo::SaveGraph::Response& response);
  bool loadGraph(agnc_pgo::LoadGraph::Request& request, agnc_pgo::LoadGraph::Response& response);
  bool saveTrajectory(agnc_pgo::SaveTrajectory::Request& request,
                      agnc_pgo::SaveTrajectory::Response& response);
  bool optimize(std_srvs::Trigger::Request& request, std_srvs::Trigger::Response& response);
  bool reset(std_srvs::Trigger::Request& request, std_srvs::Trigger::Response& response);
  bool pause(std_srvs::SetBool::Request& request, std_srvs::SetBool::Response& response);
  bool setLoopClosureStatus(agnc_pgo::SetLoopClosureStatus::Request& request,
                            agnc_pgo::SetLoopClosureStatus::Response& response);

  BackendParameters parameters_;  // as at start-up; read by the worker thread's publishers
  // The parameters in force (runtime ones as last reconfigured): read by the
  // subscription callbacks and the tf timer, written by reconfigure() on the
  // same callback queue and (paused) by ~pause under reconfigure_mutex_.
  BackendParameters current_;
  boost::recursive_mutex reconfigure_mutex_;  // also the reconfigure servers' mutex
  std::unique_ptr<dynamic_reconfigure::Server<agnc_pgo::BackendConfig>> backend_server_;
  std::unique_ptr<dynamic_reconfigure::Server<agnc_pgo::GncConfig>> gnc_server_;
  VisualizerStyle style_;
  std::unique_ptr<BackendWorker> worker_;
  ros::Subscriber odometry_subscriber_, loop_closure_subscriber_;
  ros::Publisher path_publisher_, marker_publisher_, pose_graph_publisher_, status_publisher_;
  ros::Publisher keyframe_publisher_;
  std::vector<ros::ServiceServer> services_;
  ros::WallTimer tf_timer_;
  std::unique_ptr<tf2_ros::TransformBroadcaster> broadcaster_;
  ros::Time last_tf_stamp_;
  bool warned_frame_ = false;
};

}  // namespace ros_backend
}  // namespace agnc_pgo
