#include "agnc_pgo/ros/graph_io.h"

#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "agnc_pgo/core/g2o_io.h"

namespace agnc_pgo {
namespace ros_backend {
namespace {

constexpr const char* kMagic = "agnc_pgo_sidecar";
constexpr int kVersion = 1;

void writePose(std::ostream& out, const core::Pose& p) {
  out << p.translation.x() << ' ' << p.translation.y() << ' ' << p.translation.z() << ' ' << p.rotation.x()
      << ' ' << p.rotation.y() << ' ' << p.rotation.z() << ' ' << p.rotation.w();
}

core::Pose readPose(std::istream& in) {
  double x, y, z, qx, qy, qz, qw;
  in >> x >> y >> z >> qx >> qy >> qz >> qw;
  core::Pose p;
  p.translation = Eigen::Vector3d(x, y, z);
  p.rotation = Eigen::Quaterniond(qw, qx, qy, qz);
  return p;
}

int modeToInt(core::LoopOverride m) { return static_cast<int>(m); }
core::LoopOverride modeFromInt(int m) {
  if (m < 0 || m > 2) throw std::runtime_error("bad override mode " + std::to_string(m));
  return static_cast<core::LoopOverride>(m);
}

// Reads "KEY value..." and checks the key.
void expect(std::istream& in, const std::string& key, const std::string& file) {
  std::string word;
  if (!(in >> word) || word != key)
    throw std::runtime_error(file + ": expected '" + key + "', found '" + word + "'");
}

}  // namespace

std::string sidecarPath(const std::string& g2o_path) { return g2o_path + ".meta"; }

void saveGraph(const SavedGraph& g, const std::string& path) {
  const size_t n = g.estimate.size();
  if (g.stamps.size() != n || g.odom_poses.size() != n)
    throw std::runtime_error("inconsistent graph (stamps/poses)");
  core::PoseGraph graph;
  graph.dimension = g.dimension;
  graph.poses = g.estimate;
  graph.fixed = {0};
  for (const core::Edge& e : g.odometry) graph.edges.push_back(e);
  for (const SavedLoop& l : g.loops) graph.edges.push_back(l.edge);
  {
    std::ofstream test(path);
    if (!test) throw std::runtime_error("cannot write " + path);
  }
  core::writeG2o(graph, path);

  const std::string meta = sidecarPath(path);
  std::ofstream out(meta);
  if (!out) throw std::runtime_error("cannot write " + meta);
  out << std::setprecision(17);
  out << kMagic << ' ' << kVersion << '\n' << "dimension " << g.dimension << '\n' << "prior ";
  writePose(out, g.prior_value);
  const int t = static_cast<int>(g.prior_information.rows());
  out << ' ' << t;
  for (int r = 0; r < t; ++r)
    for (int c = 0; c < t; ++c) out << ' ' << g.prior_information(r, c);
  out << '\n' << "nodes " << n << '\n';
  for (size_t i = 0; i < n; ++i) {
    out << "NODE " << i << ' ' << g.stamps[i].sec << ' ' << g.stamps[i].nsec << ' ';
    writePose(out, g.odom_poses[i]);
    out << '\n';
  }
  out << "odometry_edges " << g.odometry.size() << '\n' << "loops " << g.loops.size() << '\n';
  for (size_t k = 0; k < g.loops.size(); ++k) {
    const SavedLoop& l = g.loops[k];
    const core::GraduationState& s = l.graduation;
    out << "LOOP " << k << ' ' << l.edge.from << ' ' << l.edge.to << ' ' << modeToInt(l.mode) << ' ' << s.mu
        << ' ' << s.step << ' ' << s.init_step << ' ' << s.mu_init << ' ' << s.alpha << ' ' << s.steps_at_one
        << ' ' << (s.graduating ? 1 : 0) << ' ' << l.from_stamp.sec << ' ' << l.from_stamp.nsec << ' '
        << l.to_stamp.sec << ' ' << l.to_stamp.nsec << ' ' << l.score << ' ' << (l.edge.is_outlier ? 1 : 0)
        << ' ' << l.source.size() << ' ' << l.source << '\n';
  }
  if (!out) throw std::runtime_error("error writing " + meta);
}

SavedGraph loadGraph(const std::string& path, const Eigen::MatrixXd& default_prior_information) {
  core::PoseGraph graph = core::readG2o(path);  // throws ParseError naming file:line
  SavedGraph g;
  g.dimension = graph.dimension;
  g.estimate = graph.poses;
  const size_t n = graph.poses.size();
  if (n == 0) throw std::runtime_error(path + ": no poses");

  std::ifstream in(sidecarPath(path));
  if (!in) {
    // Plain g2o: synthetic stamps, edges classified by |i - j|.
    g.has_state = false;
    g.prior_value = graph.poses[0];
    g.prior_information = default_prior_information;
    for (size_t i = 0; i < n; ++i) g.stamps.emplace_back(1.0 + static_cast<double>(i));
    g.odom_poses = graph.poses;
    for (const core::Edge& e : graph.edges) {
      if (e.kind == core::EdgeKind::kOdometry && e.to == e.from + 1) {
        g.odometry.push_back(e);
      } else {
        SavedLoop l;
        l.edge = e;
        l.from_stamp = g.stamps[e.from];
        l.to_stamp = g.stamps[e.to];
        l.source = "g2o";
        g.loops.push_back(l);
      }
    }
    return g;
  }

  const std::string meta = sidecarPath(path);
  std::string magic;
  int version = 0;
  in >> magic >> version;
  if (magic != kMagic || version != kVersion) throw std::runtime_error(meta + ": not an agnc_pgo sidecar (v1)");
  expect(in, "dimension", meta);
  in >> g.dimension;
  if (g.dimension != graph.dimension) throw std::runtime_error(meta + ": dimension differs from the g2o file");
  expect(in, "prior", meta);
  g.prior_value = readPose(in);
  int t = 0;
  in >> t;
  if (t != graph.tangentDimension()) throw std::runtime_error(meta + ": bad prior size");
  g.prior_information.resize(t, t);
  for (int r = 0; r < t; ++r)
    for (int c = 0; c < t; ++c) in >> g.prior_information(r, c);
  expect(in, "nodes", meta);
  size_t nodes = 0;
  in >> nodes;
  if (!in || nodes != n) throw std::runtime_error(meta + ": node count differs from the g2o file");
  for (size_t i = 0; i < n; ++i) {
    expect(in, "NODE", meta);
    size_t id;
    uint32_t sec, nsec;
    in >> id >> sec >> nsec;
    if (!in || id != i) throw std::runtime_error(meta + ": bad NODE line " + std::to_string(i));
    g.stamps.emplace_back(sec, nsec);
    g.odom_poses.push_back(readPose(in));
  }
  size_t odometry = 0, loops = 0;
  expect(in, "odometry_edges", meta);
  in >> odometry;
  expect(in, "loops", meta);
  in >> loops;
  if (!in || odometry + loops != graph.edges.size())
    throw std::runtime_error(meta + ": edge counts differ from the g2o file");
  for (size_t k = 0; k < odometry; ++k) {
    core::Edge e = graph.edges[k];
    e.kind = core::EdgeKind::kOdometry;
    g.odometry.push_back(e);
  }
  for (size_t k = 0; k < loops; ++k) {
    SavedLoop l;
    l.edge = graph.edges[odometry + k];
    l.edge.kind = core::EdgeKind::kLoopClosure;
    expect(in, "LOOP", meta);
    size_t index;
    int from, to, mode, graduating, outlier;
    size_t source_length;
    core::GraduationState& s = l.graduation;
    in >> index >> from >> to >> mode >> s.mu >> s.step >> s.init_step >> s.mu_init >> s.alpha >>
        s.steps_at_one >> graduating >> l.from_stamp.sec >> l.from_stamp.nsec >> l.to_stamp.sec >>
        l.to_stamp.nsec >> l.score >> outlier >> source_length;
    if (!in || index != k || from != l.edge.from || to != l.edge.to)
      throw std::runtime_error(meta + ": LOOP " + std::to_string(k) + " does not match the g2o edge");
    s.graduating = graduating != 0;
    l.edge.is_outlier = outlier != 0;
    l.mode = modeFromInt(mode);
    in.get();  // the separating space
    l.source.resize(source_length);
    if (source_length > 0) in.read(&l.source[0], static_cast<std::streamsize>(source_length));
    if (!in) throw std::runtime_error(meta + ": truncated LOOP " + std::to_string(k));
    g.loops.push_back(l);
  }
  return g;
}

}  // namespace ros_backend
}  // namespace agnc_pgo
