// backend_node: the agnc_pgo/BackendNodelet in a process of its own.
#include <nodelet/loader.h>
#include <ros/ros.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, "agnc_pgo_backend");
  nodelet::Loader loader;
  nodelet::M_string remappings(ros::names::getRemappings());
  nodelet::V_string arguments;
  for (int i = 1; i < argc; ++i) arguments.push_back(argv[i]);
  if (!loader.load(ros::this_node::getName(), "agnc_pgo/BackendNodelet", remappings, arguments)) {
    ROS_FATAL("agnc_pgo: could not start the back-end (see the error above)");
    return 1;
  }
  ros::spin();
  return 0;
}
