// The core and evaluation libraries must build without ROS: no ROS header may be included
// anywhere under include/agnc_pgo/{core,eval} or src/{core,eval}.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

namespace fs = std::filesystem;

TEST(CoreIsRosFree, NoRosIncludes) {
  const std::regex ros_include(
      R"(#\s*include\s*[<"](ros/|roscpp|nodelet/|tf2|tf2_ros/|pluginlib/|rviz/|std_msgs/|geometry_msgs/|nav_msgs/|visualization_msgs/|sensor_msgs/|agnc_pgo/ros/))");
  int files = 0;
  for (const std::string dir : {"/include/agnc_pgo/core", "/src/core", "/include/agnc_pgo/eval", "/src/eval"}) {
    for (const auto& entry : fs::recursive_directory_iterator(std::string(AGNC_PGO_SOURCE_DIR) + dir)) {
      if (!entry.is_regular_file()) continue;
      ++files;
      std::ifstream in(entry.path());
      std::string line;
      int number = 0;
      while (std::getline(in, line)) {
        ++number;
        EXPECT_FALSE(std::regex_search(line, ros_include)) << entry.path() << ":" << number << ": " << line;
      }
    }
  }
  EXPECT_GT(files, 10);  // the scan really saw the library
}

TEST(CoreIsRosFree, TheCheckRecognisesRosIncludes) {
  const std::regex ros_include(R"(#\s*include\s*[<"](ros/|tf2_ros/))");
  EXPECT_TRUE(std::regex_search("#include <ros/ros.h>", ros_include));
  EXPECT_TRUE(std::regex_search("#include \"tf2_ros/buffer.h\"", ros_include));
  EXPECT_FALSE(std::regex_search("#include <ceres/ceres.h>", ros_include));
}
