// The core and evaluation libraries must build without ROS: no ROS header may be included
// anywhere under include/agnc_pgo/{core,eval} or src/{core,eval}.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

// The lines of the files under `dirs` (relative to `root`) that include a
// ROS header, as "path:line: text"; `files` counts the files read.
std::vector<std::string> rosIncludes(const std::string& root, const std::vector<std::string>& dirs,
                                     int* files) {
  const std::regex ros_include(
      R"(#\s*include\s*[<"](ros/|roscpp|nodelet/|tf2|tf2_ros/|pluginlib/|rviz/|std_msgs/|geometry_msgs/|nav_msgs/|visualization_msgs/|sensor_msgs/|agnc_pgo/ros/))");
  std::vector<std::string> found;
  *files = 0;
  for (const std::string& dir : dirs) {
    for (const auto& entry : fs::recursive_directory_iterator(root + dir)) {
      if (!entry.is_regular_file()) continue;
      ++*files;
      std::ifstream in(entry.path());
      std::string line;
      int number = 0;
      while (std::getline(in, line)) {
        ++number;
        if (std::regex_search(line, ros_include))
          found.push_back(entry.path().string() + ":" + std::to_string(number) + ": " + line);
      }
    }
  }
  return found;
}

}  // namespace

TEST(CoreIsRosFree, NoRosIncludes) {
  int files = 0;
  const std::vector<std::string> found = rosIncludes(
      AGNC_PGO_SOURCE_DIR, {"/include/agnc_pgo/core", "/src/core", "/include/agnc_pgo/eval", "/src/eval"}, &files);
  for (const std::string& line : found) ADD_FAILURE() << line;
  EXPECT_GT(files, 10);  // the scan really saw the library
}

// The same scan over a tree written here: it finds the ROS includes, spelled
// in several ways, and nothing else.
TEST(CoreIsRosFree, TheCheckRecognisesRosIncludes) {
  const fs::path root = fs::temp_directory_path() / ("agnc_ros_free_" + std::to_string(::getpid()));
  fs::create_directories(root / "src");
  std::ofstream(root / "src" / "a.cc") << "#include <ros/ros.h>\n#include <ceres/ceres.h>\n"
                                          "#  include \"tf2_ros/buffer.h\"\n#include <Eigen/Core>\n";
  std::ofstream(root / "src" / "b.h") << "#include \"agnc_pgo/ros/backend_graph.h\"\n"
                                         "#include \"agnc_pgo/core/pose.h\"\n";
  int files = 0;
  const std::vector<std::string> found = rosIncludes(root.string(), {"/src"}, &files);
  fs::remove_all(root);
  EXPECT_EQ(files, 2);
  ASSERT_EQ(found.size(), 3u);
  for (const std::string& line : found)
    EXPECT_TRUE(line.find("ros/ros.h") != std::string::npos || line.find("tf2_ros/buffer.h") != std::string::npos ||
                line.find("agnc_pgo/ros/") != std::string::npos)
        << line;
}
