// libFuzzer target: the g2o reader (core readG2o).
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <stdexcept>

#include "fuzz_oracles.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace agnc_pgo;
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  core::PoseGraph graph;
  try {
    graph = core::readG2o(in, "fuzz.g2o");
  } catch (const std::runtime_error&) {
    return 0;  // refused with a message: fine
  }
  fuzz::checkGraph(graph);
  fuzz::checkRoundTrip(graph);
  return 0;
}
