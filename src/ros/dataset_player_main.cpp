// dataset_player: a stand-in front-end. Publishes a dataset's keyframes as
// ~odom (nav_msgs/Odometry, pose = composed odometry, pose.covariance = the
// odometry edge's covariance) plus odom -> base_link tf, and its loop
// closures as ~loop_closures (source = "true" / "outlier": the ground-truth
// label), at ~rate entries per second. ~done (latched) turns true at the end.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <std_msgs/Bool.h>
#include <tf2_ros/transform_broadcaster.h>

#include "agnc_pgo/LoopClosure.h"
#include "agnc_pgo/ros/conversions.h"
#include "agnc_pgo/ros/dataset_player.h"

using namespace agnc_pgo::ros_backend;

namespace {

geometry_msgs::TransformStamped transform(const agnc_pgo::core::Pose& p, const ros::Time& stamp,
                                          const std::string& frame, const std::string& child) {
  geometry_msgs::TransformStamped t;
  t.header.stamp = stamp;
  t.header.frame_id = frame;
  t.child_frame_id = child;
  const geometry_msgs::Pose m = toMsg(p);
  t.transform.translation.x = m.position.x;
  t.transform.translation.y = m.position.y;
  t.transform.translation.z = m.position.z;
  t.transform.rotation = m.orientation;
  return t;
}

// The node's parameters, read once.
struct PlayerParameters {
  std::string dataset, frame = "odom", child = "base_link";
  double outliers = 0.0, rate = 200.0, start_delay = 1.0, subscriber_timeout = 15.0;
  int seed = 1;
  std::string outlier_mode = "random";
  int group_size = agnc_pgo::core::kDefaultGroupSize;
  bool wait_for_subscribers = true;
};

// False (after a ROS_FATAL saying why) if a parameter is missing or invalid.
bool readParameters(const ros::NodeHandle& pnh, PlayerParameters* p) {
  if (!pnh.getParam("dataset", p->dataset)) {
    ROS_FATAL("dataset_player: ~dataset (a .g2o or .irl file) is required");
    return false;
  }
  pnh.getParam("outliers", p->outliers);
  pnh.getParam("seed", p->seed);
  pnh.getParam("outlier_mode", p->outlier_mode);
  pnh.getParam("group_size", p->group_size);
  pnh.getParam("rate", p->rate);
  pnh.getParam("frame_id", p->frame);
  pnh.getParam("child_frame_id", p->child);
  pnh.getParam("start_delay", p->start_delay);
  pnh.getParam("wait_for_subscribers", p->wait_for_subscribers);
  pnh.getParam("subscriber_timeout", p->subscriber_timeout);
  if (!(p->rate > 0) || p->seed < 0) {
    ROS_FATAL("dataset_player: ~rate must be > 0 and ~seed >= 0");
    return false;
  }
  return true;
}

class Player {
 public:
  Player(ros::NodeHandle& pnh, const PlayerParameters& params, const PlayerDataset& data)
      : params_(params),
        data_(data),
        odom_pub_(pnh.advertise<nav_msgs::Odometry>("odom", 10000)),
        loop_pub_(pnh.advertise<agnc_pgo::LoopClosure>("loop_closures", 10000)),
        done_pub_(pnh.advertise<std_msgs::Bool>("done", 1, true)),
        stamps_(data.poses) {
    publishDone(false);
  }

  // Waits (at most ~subscriber_timeout) until both streams have a subscriber.
  void waitForSubscribers() const {
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(params_.subscriber_timeout);
    while (ros::ok() && !subscribed() && ros::WallTime::now() < deadline) ros::WallDuration(0.05).sleep();
    if (!subscribed())
      ROS_WARN("dataset_player: no subscriber on ~odom and ~loop_closures after %.0f s, playing anyway",
               params_.subscriber_timeout);
  }

  // Publishes every entry at ~rate; false if ROS shut down first.
  bool play() {
    // Keyframe stamps: synthetic and strictly increasing, one entry period apart.
    const ros::Time t0 = ros::Time::now();
    const ros::WallTime w0 = ros::WallTime::now();
    size_t k = 0;
    const double tick = std::min(0.01, 1.0 / params_.rate);
    while (ros::ok() && k < data_.entries.size()) {
      const double due = (ros::WallTime::now() - w0).toSec() * params_.rate;
      for (; k < data_.entries.size() && static_cast<double>(k) <= due; ++k)
        publish(data_.entries[k], t0 + ros::Duration(static_cast<double>(k) / params_.rate));
      ros::WallDuration(tick).sleep();
    }
    if (!ros::ok()) return false;
    ROS_INFO("dataset_player: done (%zu entries in %.1f s)", k, (ros::WallTime::now() - w0).toSec());
    publishDone(true);
    return true;
  }

  // Keeps the robot visible: odom -> base_link at 10 Hz until shutdown.
  void holdLastPose() {
    ros::Rate r(10.0);
    while (ros::ok()) {
      broadcaster_.sendTransform(transform(last_pose_, ros::Time::now(), params_.frame, params_.child));
      r.sleep();
    }
  }

 private:
  bool subscribed() const { return odom_pub_.getNumSubscribers() > 0 && loop_pub_.getNumSubscribers() > 0; }

  void publishDone(bool done) {
    std_msgs::Bool msg;
    msg.data = done;
    done_pub_.publish(msg);
  }

  void publish(const PlayerEntry& e, const ros::Time& stamp) {
    if (e.type == PlayerEntry::Type::kPose) {
      stamps_[e.pose] = stamp;
      nav_msgs::Odometry odom;
      odom.header.stamp = stamp;
      odom.header.frame_id = params_.frame;
      odom.child_frame_id = params_.child;
      odom.pose.pose = toMsg(e.odom_pose);
      odom.pose.covariance = covarianceFromInformation(e.information, data_.dimension);
      odom.twist.covariance[0] = -1;  // twist unknown
      odom_pub_.publish(odom);
      broadcaster_.sendTransform(transform(e.odom_pose, stamp, params_.frame, params_.child));
      last_pose_ = e.odom_pose;
      return;
    }
    agnc_pgo::LoopClosure loop;
    loop.header.stamp = stamp;
    loop.header.frame_id = params_.child;
    loop.from_stamp = stamps_[e.loop.from];
    loop.to_stamp = stamps_[e.loop.to];
    loop.relative_pose = toMsg(e.loop.measurement);
    loop.covariance = covarianceFromInformation(e.loop.information, data_.dimension);
    loop.source = e.loop.is_outlier ? "outlier" : "true";
    loop.score = 1.0;
    loop_pub_.publish(loop);
  }

  const PlayerParameters& params_;
  const PlayerDataset& data_;
  ros::Publisher odom_pub_, loop_pub_, done_pub_;
  tf2_ros::TransformBroadcaster broadcaster_;
  std::vector<ros::Time> stamps_;  // per pose, the stamp its keyframe was published with
  agnc_pgo::core::Pose last_pose_;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "dataset_player");
  ros::NodeHandle pnh("~");
  PlayerParameters params;
  if (!readParameters(pnh, &params)) return 1;

  PlayerDataset data;
  try {
    data = loadPlayerDataset(params.dataset, params.outliers, static_cast<unsigned long>(params.seed),
                             agnc_pgo::core::parseOutlierMode(params.outlier_mode), params.group_size);
  } catch (const std::exception& e) {
    ROS_FATAL_STREAM("dataset_player: " << e.what());
    return 1;
  }
  ROS_INFO_STREAM("dataset_player: " << data.name << " (" << data.dimension << "D): " << data.poses << " poses, "
                                     << data.loop_closures << " loop closures (" << data.outliers
                                     << " outliers), " << data.entries.size() << " entries at " << params.rate
                                     << "/s");

  Player player(pnh, params, data);
  if (params.wait_for_subscribers) player.waitForSubscribers();
  ros::WallDuration(params.start_delay).sleep();
  if (player.play()) player.holdLastPose();
  return 0;
}
