// A downstream program against agnc_pgo's core library: a square driven
// twice with two true loop closures and one false one; the false one must be
// rejected and the true ones kept. Exit 0 when that holds.
#include <cmath>
#include <iostream>

#include <agnc_pgo/core/gnc_options.h>
#include <agnc_pgo/core/incremental_gnc.h>

using agnc_pgo::core::Edge;
using agnc_pgo::core::EdgeKind;
using agnc_pgo::core::GncOptions;
using agnc_pgo::core::IncrementalGnc;
using agnc_pgo::core::Pose;

Edge edge(int from, int to, const Pose& z, EdgeKind kind) {
  Edge e;
  e.from = from;
  e.to = to;
  e.measurement = z;
  e.information = 100.0 * Eigen::Matrix3d::Identity();
  e.kind = kind;
  return e;
}

int main() {
  IncrementalGnc engine(2, GncOptions());
  engine.addFirstPose(Pose::identity(), 1e6 * Eigen::Matrix3d::Identity());
  const Pose side = Pose::fromSE2(1.0, 0.0, M_PI / 2);  // one side of the unit square, then turn left
  for (int k = 0; k < 8; ++k) engine.addOdometry(edge(k, k + 1, side, EdgeKind::kOdometry));
  engine.addLoopClosure(edge(0, 4, Pose::identity(), EdgeKind::kLoopClosure));        // true: same corner
  engine.addLoopClosure(edge(1, 5, Pose::identity(), EdgeKind::kLoopClosure));        // true
  engine.addLoopClosure(edge(2, 7, Pose::fromSE2(4.0, 5.0, 0.0), EdgeKind::kLoopClosure));  // false
  const auto stats = engine.update();

  const auto& loops = engine.loopClosures();
  const bool ok = loops.size() == 3 && loops[0].inlier && loops[1].inlier && !loops[2].inlier;
  for (const auto& loop : loops)
    std::cout << "loop " << loop.edge.from << "-" << loop.edge.to << ": " << (loop.inlier ? "inlier" : "outlier")
              << " (distance " << loop.distance << ", weight " << loop.weight << ")\n";
  const Pose last = engine.pose(8);
  std::cout << "poses " << engine.numPoses() << ", GNC steps " << stats.gnc_steps << ", pose 8 at ("
            << last.translation.x() << ", " << last.translation.y() << ")\n";
  std::cout << (ok ? "agnc_pgo_consumer: OK" : "agnc_pgo_consumer: WRONG classification") << std::endl;
  return ok ? 0 : 1;
}
