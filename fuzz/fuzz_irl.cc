// libFuzzer target: the .irl reader (core readIrl), and the graph it builds.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <stdexcept>

#include "agnc_pgo/eval/incremental_log.h"
#include "agnc_pgo/eval/irl_io.h"
#include "fuzz_oracles.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace agnc_pgo;
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  core::IncrementalLog log;
  try {
    log = core::readIrl(in, "fuzz.irl");
  } catch (const std::runtime_error&) {
    return 0;
  }
  AGNC_FUZZ_CHECK(log.dimension == 2 || log.dimension == 3);
  const int n = log.dimension == 2 ? 3 : 6;
  for (const core::LogEntry& e : log.entries) {
    fuzz::checkPose(e.edge.measurement);
    fuzz::checkInformation(e.edge.information, n);
  }
  core::PoseGraph graph;
  try {
    graph = core::graphFromLog(log);
  } catch (const std::runtime_error&) {
    return 0;  // e.g. a log without odometry to compose
  }
  fuzz::checkGraph(graph);
  if (!graph.poses.empty()) fuzz::checkRoundTrip(graph);
  return 0;
}
