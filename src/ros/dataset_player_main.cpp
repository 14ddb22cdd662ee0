// dataset_player: a stand-in front-end. Publishes a dataset's keyframes as
// ~odom (nav_msgs/Odometry, pose = composed odometry, pose.covariance = the
// odometry edge's covariance) plus odom -> base_link tf, and its loop
// closures as ~loop_closures (source = "true" / "outlier": the ground-truth
// label), at ~rate entries per second. ~done (latched) turns true at the end.
#include <algorithm>
#include <cmath>

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

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "dataset_player");
  ros::NodeHandle pnh("~");
  std::string dataset, frame = "odom", child = "base_link";
  double outliers = 0.0, rate = 200.0, start_delay = 1.0, subscriber_timeout = 15.0;
  int seed = 1;
  std::string outlier_mode = "random";
  int group_size = agnc_pgo::core::kDefaultGroupSize;
  bool wait_for_subscribers = true;
  if (!pnh.getParam("dataset", dataset)) {
    ROS_FATAL("dataset_player: ~dataset (a .g2o or .irl file) is required");
    return 1;
  }
  pnh.getParam("outliers", outliers);
  pnh.getParam("seed", seed);
  pnh.getParam("outlier_mode", outlier_mode);
  pnh.getParam("group_size", group_size);
  pnh.getParam("rate", rate);
  pnh.getParam("frame_id", frame);
  pnh.getParam("child_frame_id", child);
  pnh.getParam("start_delay", start_delay);
  pnh.getParam("wait_for_subscribers", wait_for_subscribers);
  pnh.getParam("subscriber_timeout", subscriber_timeout);
  if (!(rate > 0) || seed < 0) {
    ROS_FATAL("dataset_player: ~rate must be > 0 and ~seed >= 0");
    return 1;
  }

  PlayerDataset data;
  try {
    data = loadPlayerDataset(dataset, outliers, static_cast<unsigned long>(seed),
                             agnc_pgo::core::parseOutlierMode(outlier_mode), group_size);
  } catch (const std::exception& e) {
    ROS_FATAL_STREAM("dataset_player: " << e.what());
    return 1;
  }
  ROS_INFO_STREAM("dataset_player: " << data.name << " (" << data.dimension << "D): " << data.poses << " poses, "
                                     << data.loop_closures << " loop closures (" << data.outliers
                                     << " outliers), " << data.entries.size() << " entries at " << rate << "/s");

  ros::Publisher odom_pub = pnh.advertise<nav_msgs::Odometry>("odom", 10000);
  ros::Publisher loop_pub = pnh.advertise<agnc_pgo::LoopClosure>("loop_closures", 10000);
  ros::Publisher done_pub = pnh.advertise<std_msgs::Bool>("done", 1, true);
  tf2_ros::TransformBroadcaster broadcaster;
  std_msgs::Bool done;
  done.data = false;
  done_pub.publish(done);

  if (wait_for_subscribers) {
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(subscriber_timeout);
    while (ros::ok() && (odom_pub.getNumSubscribers() == 0 || loop_pub.getNumSubscribers() == 0) &&
           ros::WallTime::now() < deadline)
      ros::WallDuration(0.05).sleep();
    if (odom_pub.getNumSubscribers() == 0 || loop_pub.getNumSubscribers() == 0)
      ROS_WARN("dataset_player: no subscriber on ~odom and ~loop_closures after %.0f s, playing anyway",
               subscriber_timeout);
  }
  ros::WallDuration(start_delay).sleep();

  // Keyframe stamps: synthetic and strictly increasing, one entry period apart.
  const ros::Time t0 = ros::Time::now();
  const ros::WallTime w0 = ros::WallTime::now();
  std::vector<ros::Time> stamps(data.poses);
  agnc_pgo::core::Pose last_pose;
  size_t k = 0;
  const double tick = std::min(0.01, 1.0 / rate);
  while (ros::ok() && k < data.entries.size()) {
    const double due = (ros::WallTime::now() - w0).toSec() * rate;
    while (k < data.entries.size() && static_cast<double>(k) <= due) {
      const PlayerEntry& e = data.entries[k];
      const ros::Time stamp = t0 + ros::Duration(static_cast<double>(k) / rate);
      if (e.type == PlayerEntry::Type::kPose) {
        stamps[e.pose] = stamp;
        nav_msgs::Odometry odom;
        odom.header.stamp = stamp;
        odom.header.frame_id = frame;
        odom.child_frame_id = child;
        odom.pose.pose = toMsg(e.odom_pose);
        odom.pose.covariance = covarianceFromInformation(e.information, data.dimension);
        odom.twist.covariance[0] = -1;  // twist unknown
        odom_pub.publish(odom);
        broadcaster.sendTransform(transform(e.odom_pose, stamp, frame, child));
        last_pose = e.odom_pose;
      } else {
        agnc_pgo::LoopClosure loop;
        loop.header.stamp = stamp;
        loop.header.frame_id = child;
        loop.from_stamp = stamps[e.loop.from];
        loop.to_stamp = stamps[e.loop.to];
        loop.relative_pose = toMsg(e.loop.measurement);
        loop.covariance = covarianceFromInformation(e.loop.information, data.dimension);
        loop.source = e.loop.is_outlier ? "outlier" : "true";
        loop.score = 1.0;
        loop_pub.publish(loop);
      }
      ++k;
    }
    ros::WallDuration(tick).sleep();
  }
  if (!ros::ok()) return 0;
  ROS_INFO("dataset_player: done (%zu entries in %.1f s)", k, (ros::WallTime::now() - w0).toSec());
  done.data = true;
  done_pub.publish(done);
  // Keep the robot visible: odom -> base_link at 10 Hz.
  ros::Rate r(10.0);
  while (ros::ok()) {
    broadcaster.sendTransform(transform(last_pose, ros::Time::now(), frame, child));
    r.sleep();
  }
  return 0;
}
