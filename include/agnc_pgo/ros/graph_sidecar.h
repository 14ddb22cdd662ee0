// The back-end's graph sidecar (FILE.meta next to FILE, a g2o file): what a
// g2o file cannot hold (keyframe stamps and odometry poses, the prior, which
// edges are odometry, each loop closure's state (core::LoopClosureState),
// stamps, source and score). ROS-free, so the fuzz target can call the parser.
//
// Format (version 4; version 3, without the count of the map's judgements
// per loop closure, and version 2, without the engine's three flags either,
// are read as well, what they lack unset), one record per line:
//   agnc_pgo_sidecar 4
//   g2o BYTES CRC32          the g2o file this sidecar belongs to
//   dimension D
//   prior x y z qx qy qz qw T  then T*T information entries (row-major)
//   nodes N                  then N lines NODE i sec nsec x y z qx qy qz qw
//   odometry_edges K         the first K g2o edges are odometry
//   loops L                  then L lines LOOP (see formatSidecar)
//   checksum CRC32           of every byte before this line
// A sidecar is accepted only if its own checksum holds, it belongs to the
// g2o bytes it is paired with, and every value is within its domain.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "agnc_pgo/core/graduation_schedule.h"
#include "agnc_pgo/core/incremental_gnc.h"
#include "agnc_pgo/core/pose_graph.h"

namespace agnc_pgo {
namespace ros_backend {

struct SidecarStamp {
  uint32_t sec = 0, nsec = 0;
  bool operator<=(const SidecarStamp& o) const { return sec < o.sec || (sec == o.sec && nsec <= o.nsec); }
};

struct SidecarLoop {
  int from = 0, to = 0;
  core::LoopClosureState state;
  SidecarStamp from_stamp, to_stamp;
  std::string source;  // at most kMaxSourceBytes
  double score = 0.0;
  bool is_outlier = false;
};

struct Sidecar {
  int dimension = 2;
  std::size_t g2o_bytes = 0;
  unsigned long g2o_crc = 0;
  core::Pose prior_value;
  Eigen::MatrixXd prior_information;
  std::vector<SidecarStamp> stamps;  // one per node
  core::Poses odom_poses;            // one per node
  std::size_t odometry_edges = 0;
  std::vector<SidecarLoop> loops;
};

constexpr std::size_t kMaxSourceBytes = 4096;

// The sidecar text for a g2o file whose exact bytes are g2o_text (their size
// and CRC-32 are recorded; g2o_bytes/g2o_crc of `sidecar` are ignored).
// Throws std::invalid_argument for a value that could not be read back
// (non-finite, out of its domain).
std::string formatSidecar(const Sidecar& sidecar, const std::string& g2o_text);

// Parses and validates a sidecar on its own (checksum, syntax, domains).
// Throws core::ParseError ("NAME:LINE: reason").
Sidecar parseSidecar(const std::string& text, const std::string& name);

// "" if the sidecar belongs to these g2o bytes and the graph parsed from them
// (size, CRC-32, node and edge counts, loop endpoints), else the reason.
std::string sidecarMismatch(const Sidecar& sidecar, const std::string& g2o_text, const core::PoseGraph& graph);

}  // namespace ros_backend
}  // namespace agnc_pgo
