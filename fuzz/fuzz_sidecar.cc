// libFuzzer target: the back-end's graph sidecar parser (ROS-free), paired
// with a fixed small g2o graph as loadGraph pairs them.
#include <cstddef>
#include <cmath>
#include <cstdint>
#include <stdexcept>

#include "agnc_pgo/ros/graph_sidecar.h"
#include "fuzz_oracles.h"


extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace agnc_pgo;
  using namespace agnc_pgo::ros_backend;
  const std::string text(reinterpret_cast<const char*>(data), size);
  Sidecar sidecar;
  try {
    sidecar = parseSidecar(text, "fuzz.g2o.meta");
  } catch (const std::runtime_error&) {
    return 0;
  }
  // Everything parsed is in its domain.
  AGNC_FUZZ_CHECK(sidecar.dimension == 2 || sidecar.dimension == 3);
  AGNC_FUZZ_CHECK(sidecar.stamps.size() == sidecar.odom_poses.size());
  fuzz::checkPose(sidecar.prior_value);
  fuzz::checkInformation(sidecar.prior_information, sidecar.dimension == 2 ? 3 : 6);
  for (const core::Pose& p : sidecar.odom_poses) fuzz::checkPose(p);
  for (const SidecarLoop& l : sidecar.loops) {
    AGNC_FUZZ_CHECK(l.from >= 0 && l.to >= 0 && static_cast<size_t>(std::max(l.from, l.to)) < sidecar.stamps.size());
    AGNC_FUZZ_CHECK(l.state.graduation.mu >= 0 && l.state.graduation.mu <= 1 && std::isfinite(l.score));
    AGNC_FUZZ_CHECK(l.source.size() <= kMaxSourceBytes);
  }
  // Paired with the g2o: a match means every index is in range.
  const core::PoseGraph& graph = fuzz::fixedGraph();
  const std::string g2o = fuzz::g2oText(graph);
  if (sidecarMismatch(sidecar, g2o, graph).empty()) {
    AGNC_FUZZ_CHECK(sidecar.odometry_edges + sidecar.loops.size() == graph.edges.size());
  }
  // Written again, it parses to the same text.
  const std::string again = formatSidecar(sidecar, g2o);
  const std::string third = formatSidecar(parseSidecar(again, "round-trip"), g2o);
  AGNC_FUZZ_CHECK(again == third);
  return 0;
}
