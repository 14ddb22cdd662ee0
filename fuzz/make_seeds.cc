// Writes the fuzz targets' seed corpus: SEEDS/g2o, SEEDS/irl, SEEDS/sidecar,
// small valid files of every record type (the fuzzer mutates from there).
#include <sys/stat.h>

#include <fstream>
#include <iostream>
#include <string>

#include "agnc_pgo/ros/graph_sidecar.h"
#include "fuzz_oracles.h"

namespace {

using namespace agnc_pgo;

void write(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  if (!out) {
    std::cerr << "cannot write " << path << "\n";
    std::exit(1);
  }
}

core::PoseGraph graph3D() {
  core::PoseGraph g;
  g.dimension = 3;
  core::Pose pose;
  const core::Pose step = core::Pose::fromXYZRPY(1.0, 0.2, 0.1, 0.05, -0.02, 0.3);
  for (int i = 0; i < 4; ++i, pose = pose * step) g.poses.push_back(pose);
  for (int i = 0; i < 4; ++i) {
    core::Edge e;
    e.from = i;
    e.to = (i + 1) % 4;
    e.measurement = i < 3 ? step : g.poses[3].inverse() * g.poses[0];
    e.information = Eigen::MatrixXd::Identity(6, 6) * 4.0;
    e.information(0, 1) = e.information(1, 0) = 0.5;
    e.kind = core::classifyEdge(e.from, e.to);
    g.edges.push_back(e);
  }
  g.fixed = {0};
  return g;
}

ros_backend::Sidecar sidecarOfFixedGraph() {
  ros_backend::Sidecar s;
  s.dimension = 2;
  s.prior_information = Eigen::Matrix3d::Identity() * 1e8;
  for (int i = 0; i < 6; ++i) {
    s.stamps.push_back({static_cast<uint32_t>(100 + i), static_cast<uint32_t>(1000 * i)});
    s.odom_poses.push_back(core::Pose::fromSE2(i, 0.5 * i, 0.1 * i));
  }
  s.odometry_edges = 5;
  for (int k = 0; k < 2; ++k) {
    ros_backend::SidecarLoop l;
    l.from = k == 0 ? 5 : 4;
    l.to = k == 0 ? 0 : 1;
    l.state.graduation.mu = 0.5;
    l.state.graduation.step = 3;
    l.state.graduation.alpha = 0.25;
    l.state.graduation.graduating = k == 1;
    l.state.override_mode = core::LoopOverride::kForceInlier;
    l.from_stamp = s.stamps[l.from];
    l.to_stamp = s.stamps[l.to];
    l.source = k == 0 ? "front end" : "outlier %";
    l.score = 0.75;
    s.loops.push_back(l);
  }
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: make_seeds DIR\n";
    return 2;
  }
  const std::string dir = argv[1];
  for (const char* sub : {"", "/g2o", "/irl", "/sidecar"}) ::mkdir((dir + sub).c_str(), 0755);
  write(dir + "/g2o/fixed2d.g2o", fuzz::g2oText(fuzz::fixedGraph()));
  write(dir + "/g2o/ring3d.g2o", fuzz::g2oText(graph3D()));
  write(dir + "/g2o/edges_only.g2o",
        "# no vertices\nEDGE_SE2 0 1 1 0 0.1 10 0 0 10 0 10\nEDGE_SE2 2 1 -1 0 -0.1 10 0 0 10 0 10\n"
        "EDGE_SE2 2 0 -2 0 -0.2 10 0 0 10 0 10\nFIX 0\n");
  write(dir + "/g2o/plain.g2o", "VERTEX_SE2 0 0 0 0\r\nVERTEX_SE2 1 1 0 1.5\nEDGE_SE2 0 1 1 0 1.5 1 0.1 0 1 0 1\n");
  const std::string header2 = "fuzz\n2026-01-01\n2\nnonlinear\nseed\n";
  const std::string cov2 = " 0.1 0 0 0 0.1 0 0 0 0.01";
  write(dir + "/irl/log2d.irl", header2 + "PRIOR 1 0 0 0 0 0" + cov2 + "\nODOMETRY 1 0 0 1 1 0 0.1" + cov2 +
                                    "\nODOMETRY 1 0 1 2 1 0 0.1" + cov2 + "\nLOOP 2 1 2 0 -2 0 -0.2" + cov2 +
                                    " NULL\nLOOP 1 0 2 1 -1 0 -0.1" + cov2 + "\n");
  std::string cov3;
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) cov3 += r == c ? " 0.01" : " 0";
  write(dir + "/irl/log3d.irl", "fuzz\n2026-01-01\n3\nnonlinear\nseed\nPRIOR 1 0 0 0 0 0 0 0 0" + cov3 +
                                    "\nODOMETRY 1 0 0 1 1 0 0 0.1 0 0.2" + cov3 + "\nLOOP 1 0 1 0 -1 0 0 -0.1 0 -0.2" +
                                    cov3 + "\n");
  write(dir + "/sidecar/fixed2d.g2o.meta",
        ros_backend::formatSidecar(sidecarOfFixedGraph(), fuzz::g2oText(fuzz::fixedGraph())));
  return 0;
}
