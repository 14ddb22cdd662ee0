// Oracles shared by the fuzz targets: beyond "no crash", everything a reader
// returns must be finite and plausible with positive-definite information,
// and a graph written and read back must give the same text again.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>

#include <Eigen/Cholesky>

#include "agnc_pgo/core/g2o_io.h"
#include "agnc_pgo/core/pose_graph.h"

namespace agnc_pgo {
namespace fuzz {

[[noreturn]] inline void oracleFailed(const char* what) {
  std::fprintf(stderr, "fuzz oracle failed: %s\n", what);
  std::abort();
}

#define AGNC_FUZZ_CHECK(condition) \
  do {                             \
    if (!(condition)) ::agnc_pgo::fuzz::oracleFailed(#condition); \
  } while (0)

inline void checkPose(const core::Pose& p) {
  AGNC_FUZZ_CHECK(p.translation.allFinite());
  AGNC_FUZZ_CHECK(p.translation.cwiseAbs().maxCoeff() <= 2e9);  // 1e9 per file value, composed twice at most
  AGNC_FUZZ_CHECK(p.rotation.coeffs().allFinite());
  AGNC_FUZZ_CHECK(std::abs(p.rotation.norm() - 1.0) < 1e-9);
}

inline void checkInformation(const Eigen::MatrixXd& info, int n) {
  AGNC_FUZZ_CHECK(info.rows() == n && info.cols() == n);
  AGNC_FUZZ_CHECK(info.allFinite());
  AGNC_FUZZ_CHECK(Eigen::LLT<Eigen::MatrixXd>(info).info() == Eigen::Success);
}

inline void checkGraph(const core::PoseGraph& g) {
  AGNC_FUZZ_CHECK(g.dimension == 2 || g.dimension == 3);
  for (const core::Pose& p : g.poses) checkPose(p);
  const int n = static_cast<int>(g.poses.size());
  for (const core::Edge& e : g.edges) {
    AGNC_FUZZ_CHECK(e.from >= 0 && e.from < n && e.to >= 0 && e.to < n && e.from != e.to);
    checkPose(e.measurement);
    checkInformation(e.information, g.tangentDimension());
  }
  for (int id : g.fixed) AGNC_FUZZ_CHECK(id >= 0 && id < n);
  // The file's ids, where kept, name every pose once and in order.
  AGNC_FUZZ_CHECK(g.file_ids.empty() || static_cast<int>(g.file_ids.size()) == n);
  for (size_t k = 0; k < g.file_ids.size(); ++k)
    AGNC_FUZZ_CHECK(g.file_ids[k] >= 0 && (k == 0 || g.file_ids[k] > g.file_ids[k - 1]));
}

inline std::string g2oText(const core::PoseGraph& g) {
  std::ostringstream out;
  core::writeG2o(g, out);
  return out.str();
}

// A written graph reads back to the same graph: the same text once more.
inline void checkRoundTrip(const core::PoseGraph& g) {
  const std::string text = g2oText(g);
  std::istringstream in(text);
  const core::PoseGraph back = core::readG2o(in, "round-trip");  // must not throw
  checkGraph(back);
  AGNC_FUZZ_CHECK(back.poses.size() == g.poses.size() && back.edges.size() == g.edges.size());
  AGNC_FUZZ_CHECK(back.file_ids == g.file_ids);
  AGNC_FUZZ_CHECK(g2oText(back) == text);
}

// The g2o graph the sidecar target pairs its input with (and the seed
// sidecar belongs to): 6 poses, 5 odometry edges, 2 loop closures.
inline const core::PoseGraph& fixedGraph() {
  using namespace core;
  static const PoseGraph graph = [] {
    PoseGraph g;
    g.dimension = 2;
    for (int i = 0; i < 6; ++i) g.poses.push_back(Pose::fromSE2(i, 0.5 * i, 0.1 * i));
    const auto edge = [](int from, int to, const Pose& z, EdgeKind kind) {
      Edge e;
      e.from = from;
      e.to = to;
      e.measurement = z;
      e.information = Eigen::Matrix3d::Identity() * 10.0;
      e.kind = kind;
      return e;
    };
    for (int i = 0; i < 5; ++i) g.edges.push_back(edge(i, i + 1, Pose::fromSE2(1, 0.5, 0.1), EdgeKind::kOdometry));
    g.edges.push_back(edge(5, 0, Pose::fromSE2(-5, -2.5, -0.5), EdgeKind::kLoopClosure));
    g.edges.push_back(edge(4, 1, Pose::fromSE2(-3, -1.5, -0.3), EdgeKind::kLoopClosure));
    g.fixed = {0};
    return g;
  }();
  return graph;
}

}  // namespace fuzz
}  // namespace agnc_pgo
