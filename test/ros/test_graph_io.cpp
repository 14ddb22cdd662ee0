// The back-end's saved graph (g2o + sidecar): crash-free and lossless.
// Damaged, mismatched or out-of-domain pairs are refused with the file and
// reason; save -> load -> save is byte-identical; a save interrupted between
// its two renames is recovered; no count in a sidecar can index out of range.
#include <unistd.h>

#include <climits>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "agnc_pgo/core/atomic_file.h"
#include "agnc_pgo/core/g2o_io.h"
#include "agnc_pgo/ros/graph_io.h"
#include "agnc_pgo/ros/graph_sidecar.h"

namespace agnc_pgo {
namespace ros_backend {
namespace {

// A directory of this test program's own, removed when the program ends.
struct TempDirectory {
  std::string path = testing::TempDir() + "agnc_pgo_graph_io_" + std::to_string(::getpid());
  TempDirectory() { EXPECT_EQ(std::system(("rm -rf '" + path + "' && mkdir -p '" + path + "'").c_str()), 0); }
  ~TempDirectory() {
    if (std::system(("rm -rf '" + path + "'").c_str()) != 0) std::perror("rm -rf");
  }
};

std::string tempDir() {
  static const TempDirectory dir;
  return dir.path;
}

std::string readFile(const std::string& path) { return core::readWholeFile(path, 1u << 30); }
void writeFile(const std::string& path, const std::string& text) { std::ofstream(path, std::ios::binary) << text; }

Eigen::MatrixXd identity(int dimension) {
  const int t = dimension == 2 ? 3 : 6;
  return Eigen::MatrixXd::Identity(t, t);
}

// A small graph as the back-end saves it: a chain with two loop closures,
// estimate quaternions as products (as an optimiser leaves them).
SavedGraph sampleGraph(int dimension, int nodes = 30) {
  SavedGraph g;
  g.dimension = dimension;
  g.prior_value = core::Pose();
  g.prior_information = identity(dimension) * 1e8;
  core::Pose pose, odom;
  const core::Pose step2 = core::Pose::fromSE2(1.0, 0.1, 0.13);
  core::Pose step3 = core::Pose::fromXYZRPY(1.0, 0.1, 0.05, 0.01, -0.02, 0.13);
  const core::Pose& step = dimension == 2 ? step2 : step3;
  for (int i = 0; i < nodes; ++i) {
    g.stamps.push_back(ros::Time(100 + i, 5000 * i));
    g.odom_poses.push_back(odom);
    g.estimate.push_back(pose);
    odom = odom * step;
    pose = pose * step * core::Pose::fromSE2(1e-3, 0.0, 1e-4);
  }
  for (int i = 0; i + 1 < nodes; ++i) {
    core::Edge e;
    e.from = i;
    e.to = i + 1;
    e.measurement = step;
    e.information = identity(dimension) * 100.0;
    e.kind = core::EdgeKind::kOdometry;
    g.odometry.push_back(e);
  }
  for (int k = 0; k < 2 && nodes >= 4; ++k) {
    SavedLoop l;
    l.edge.from = nodes - 1 - k;
    l.edge.to = k;
    l.edge.measurement = g.estimate[l.edge.from].inverse() * g.estimate[k];
    l.edge.information = identity(dimension) * 25.0;
    l.edge.kind = core::EdgeKind::kLoopClosure;
    l.edge.is_outlier = k == 1;
    l.state.graduation.mu = k == 0 ? 1.0 : 0.25;
    l.state.graduation.step = 5;
    l.state.graduation.init_step = 3;
    l.state.graduation.alpha = 0.5;
    l.state.graduation.steps_at_one = 2;
    l.state.override_mode = k == 0 ? core::LoopOverride::kAuto : core::LoopOverride::kForceOutlier;
    l.state.uncorroborated = k == 1;
    l.state.undone = k == 1;
    l.state.landed = k == 0;
    l.state.map_judgements = k == 0 ? 3 : 0;
    l.from_stamp = g.stamps[l.edge.from];
    l.to_stamp = g.stamps[k];
    l.source = k == 0 ? "front end %1 with spaces\nand a newline" : "";
    l.score = 0.1 * (k + 1);
    g.loops.push_back(l);
  }
  return g;
}

// Rewrites the sidecar text and re-signs it, as a crafted attack would.
std::string resign(std::string text) {
  const std::size_t last = text.rfind("checksum ");
  text.erase(last);
  char crc[16];
  std::snprintf(crc, sizeof crc, "%08lx", core::crc32Of(text));
  return text + "checksum " + crc + "\n";
}

std::string replaceOnce(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

void expectLoadError(const std::string& path, const std::string& reason) {
  try {
    loadGraph(path, identity(2));
    ADD_FAILURE() << "loaded " << path;
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find(reason), std::string::npos) << e.what();
    EXPECT_LT(std::string(e.what()).size(), 600u) << e.what();
  }
}

TEST(GraphIo, SaveLoadSaveIsByteIdentical) {
  for (int dimension : {2, 3}) {
    SCOPED_TRACE(dimension);
    const std::string a = tempDir() + "/a" + std::to_string(dimension) + ".g2o";
    const std::string b = tempDir() + "/b" + std::to_string(dimension) + ".g2o";
    saveGraph(sampleGraph(dimension), a);
    const SavedGraph loaded = loadGraph(a, identity(dimension));
    EXPECT_TRUE(loaded.has_state);
    ASSERT_EQ(loaded.loops.size(), 2u);
    EXPECT_EQ(loaded.loops[0].source, "front end %1 with spaces\nand a newline");
    EXPECT_EQ(loaded.loops[1].state.override_mode, core::LoopOverride::kForceOutlier);
    EXPECT_TRUE(loaded.loops[1].edge.is_outlier);
    EXPECT_TRUE(loaded.loops[1].state.uncorroborated && loaded.loops[1].state.undone);
    EXPECT_FALSE(loaded.loops[0].state.uncorroborated || loaded.loops[0].state.undone);
    EXPECT_TRUE(loaded.loops[0].state.landed);
    EXPECT_FALSE(loaded.loops[1].state.landed);
    EXPECT_EQ(loaded.loops[0].state.map_judgements, 3);
    EXPECT_EQ(loaded.loops[1].state.map_judgements, 0);
    EXPECT_EQ(loaded.stamps[7], ros::Time(107, 35000));
    saveGraph(loaded, b);
    EXPECT_EQ(readFile(a), readFile(b));
    const std::string meta_a = readFile(sidecarPath(a)), meta_b = readFile(sidecarPath(b));
    // The sidecars differ only in nothing: same g2o bytes, same state.
    EXPECT_EQ(meta_a, meta_b);
  }
}

// The body (before its checksum line) of `path`'s sidecar as an older
// version wrote it: the version number replaced and the LOOP tokens
// [first, last) left out.
std::string olderSidecarBody(const std::string& path, int version, int first, int last) {
  std::istringstream in(readFile(sidecarPath(path)));
  std::string body;
  for (std::string line; std::getline(in, line);) {
    if (line.compare(0, 9, "checksum ") == 0) break;
    std::istringstream fields(line);
    std::vector<std::string> f;
    for (std::string t; fields >> t;) f.push_back(t);
    if (f[0] == "agnc_pgo_sidecar") f[1] = std::to_string(version);
    if (f[0] == "LOOP") f.erase(f.begin() + first, f.begin() + last);
    std::string joined;
    for (const std::string& t : f) joined += (joined.empty() ? "" : " ") + t;
    body += joined + "\n";
  }
  return body;
}

// A sidecar saved before the engine's flags were kept (version 2: LOOP
// lines without uncorroborated / undone / landed) loads, the flags unset.
TEST(GraphIo, Version2SidecarLoadsWithTheFlagsUnset) {
  const std::string path = tempDir() + "/v2.g2o";
  saveGraph(sampleGraph(2), path);
  const std::string v2 = olderSidecarBody(path, 2, 12, 16);
  writeFile(sidecarPath(path), resign(v2 + "checksum 00000000\n"));
  const SavedGraph loaded = loadGraph(path, identity(2));
  ASSERT_EQ(loaded.loops.size(), 2u);
  EXPECT_EQ(loaded.loops[1].state.override_mode, core::LoopOverride::kForceOutlier);
  EXPECT_EQ(loaded.loops[1].source, "");
  for (const SavedLoop& l : loaded.loops)
    EXPECT_FALSE(l.state.uncorroborated || l.state.undone || l.state.landed || l.state.map_judgements);
  // A version-2 line length in a version-3 file is refused.
  writeFile(sidecarPath(path), resign(replaceOnce(v2, "agnc_pgo_sidecar 2", "agnc_pgo_sidecar 3") + "checksum 00000000\n"));
  expectLoadError(path, "expected 22 tokens, got 19");
}

// A sidecar saved before the map's judgements were counted (version 3)
// loads with the flags and the count 0: those loop closures' next
// judgement is taken as their first.
TEST(GraphIo, Version3SidecarLoadsWithTheJudgementsUncounted) {
  const std::string path = tempDir() + "/v3.g2o";
  saveGraph(sampleGraph(2), path);
  const std::string v3 = olderSidecarBody(path, 3, 15, 16);
  writeFile(sidecarPath(path), resign(v3 + "checksum 00000000\n"));
  const SavedGraph loaded = loadGraph(path, identity(2));
  ASSERT_EQ(loaded.loops.size(), 2u);
  EXPECT_TRUE(loaded.loops[0].state.landed);
  EXPECT_TRUE(loaded.loops[1].state.uncorroborated && loaded.loops[1].state.undone);
  for (const SavedLoop& l : loaded.loops) EXPECT_EQ(l.state.map_judgements, 0);
  // A version-3 line length in a version-4 file is refused.
  writeFile(sidecarPath(path), resign(replaceOnce(v3, "agnc_pgo_sidecar 3", "agnc_pgo_sidecar 4") + "checksum 00000000\n"));
  expectLoadError(path, "expected 23 tokens, got 22");
}

// The reproducer of the SIGSEGV: counts whose sum wraps to the edge count.
TEST(GraphIo, SidecarCountsCannotWrapAround) {
  const std::string path = tempDir() + "/wrap.g2o";
  SavedGraph one = sampleGraph(2, 1);  // one node, no edges
  saveGraph(one, path);
  const std::string meta = readFile(sidecarPath(path));
  writeFile(sidecarPath(path), resign(replaceOnce(replaceOnce(meta, "odometry_edges 0", "odometry_edges -1"),
                                                  "loops 0", "loops 1")));
  expectLoadError(path, "odometry_edges -1 is outside");
  writeFile(sidecarPath(path),
            resign(replaceOnce(meta, "odometry_edges 0", "odometry_edges 18446744073709551615")));
  expectLoadError(path, "odometry_edges: bad integer");
  writeFile(sidecarPath(path), resign(replaceOnce(meta, "loops 0", "loops 1")));
  expectLoadError(path, "file ends early");
}

TEST(GraphIo, SidecarValuesOutOfTheirDomainAreRefused) {
  const std::string path = tempDir() + "/domain.g2o";
  saveGraph(sampleGraph(2), path);
  const std::string meta = readFile(sidecarPath(path));
  const std::size_t loop = meta.find("LOOP 0 ");
  const std::string loop_line = meta.substr(loop, meta.find('\n', loop) - loop);
  std::istringstream fields(loop_line);
  std::vector<std::string> f;
  for (std::string t; fields >> t;) f.push_back(t);
  ASSERT_EQ(f.size(), 23u);
  const auto withField = [&](int index, const std::string& value) {
    std::vector<std::string> g = f;
    g[index] = value;
    std::string line;
    for (const std::string& t : g) line += (line.empty() ? "" : " ") + t;
    return resign(replaceOnce(meta, loop_line, line));
  };
  const struct {
    int field;
    const char* value;
    const char* reason;
  } cases[] = {{5, "7", "mu 7.000000 is outside [0.000000, 1.000000]"},
               {5, "nan", "mu: non-finite value 'nan'"},
               {6, "2147483647", "step 2147483647 is outside [0, 1000]"},
               {4, "3", "override mode 3 is outside"},
               {12, "2", "uncorroborated 2 is outside [0, 1]"},
               {14, "-1", "landed -1 is outside [0, 1]"},
               {15, "-2", "map_judgements -2 is outside [0, 1000000000]"},
               {20, "nan", "score: non-finite"}};
  for (const auto& c : cases) {
    SCOPED_TRACE(c.reason);
    writeFile(sidecarPath(path), withField(c.field, c.value));
    expectLoadError(path, c.reason);
  }
  writeFile(sidecarPath(path), withField(22, "=" + std::string(5000, 'x')));
  expectLoadError(path, "source is longer than 4096 bytes");
  // A zero quaternion in a NODE's odometry pose.
  const std::size_t node = meta.find("NODE 3 ");
  const std::string node_line = meta.substr(node, meta.find('\n', node) - node);
  std::string zeroed = node_line;
  {
    std::istringstream in(node_line);
    std::vector<std::string> t;
    for (std::string s; in >> s;) t.push_back(s);
    t[7] = t[8] = t[9] = t[10] = "0";
    zeroed.clear();
    for (const std::string& s : t) zeroed += (zeroed.empty() ? "" : " ") + s;
  }
  writeFile(sidecarPath(path), resign(replaceOnce(meta, node_line, zeroed)));
  expectLoadError(path, "odometry pose quaternion is not unit length");
}

TEST(GraphIo, DamagedOrMismatchedPairsAreRefused) {
  const std::string path = tempDir() + "/pair.g2o";
  const std::string other = tempDir() + "/other.g2o";
  saveGraph(sampleGraph(2), path);
  SavedGraph changed = sampleGraph(2);
  changed.loops[0].state.override_mode = core::LoopOverride::kForceInlier;  // same counts, different state
  changed.estimate[4].translation.x() += 0.5;
  saveGraph(changed, other);
  const std::string g2o = readFile(path), meta = readFile(sidecarPath(path));

  // An old sidecar whose counts match a newer g2o.
  writeFile(sidecarPath(path), readFile(sidecarPath(other)));
  expectLoadError(path, "does not belong to");
  writeFile(sidecarPath(path), meta);
  // A sidecar cut short or altered by one byte.
  writeFile(sidecarPath(path), meta.substr(0, meta.size() - 30));
  expectLoadError(path, "file is truncated (no checksum line)");
  writeFile(sidecarPath(path), replaceOnce(meta, "LOOP 1 ", "LOOP 1  "));
  expectLoadError(path, "checksum mismatch");
  writeFile(sidecarPath(path), meta);
  // The g2o cut at a line end in its loop-closure section, with or without its sidecar.
  writeFile(path, g2o.substr(0, g2o.rfind("EDGE_SE2")));
  expectLoadError(path, "file is truncated");
  ::unlink(sidecarPath(path).c_str());
  expectLoadError(path, "file is truncated");
  // A version-1 sidecar (no checksum) is refused, not combined unchecked.
  writeFile(path, g2o);
  writeFile(sidecarPath(path), "agnc_pgo_sidecar 1\ndimension 2\n");
  expectLoadError(path, "version-1 sidecar");
}

TEST(GraphIo, SaveKilledBetweenItsRenamesIsRecovered) {
  const std::string path = tempDir() + "/killed.g2o";
  saveGraph(sampleGraph(2), path);
  SavedGraph newer = sampleGraph(2, 40);
  // Re-enact saveGraph up to the first rename (a SIGKILL between the two).
  const std::string scratch = tempDir() + "/scratch.g2o";
  saveGraph(newer, scratch);
  core::stageFile(path, readFile(scratch));
  core::stageFile(sidecarPath(path), readFile(sidecarPath(scratch)));
  {
    // Killed before either rename: the previous save loads.
    const SavedGraph old = loadGraph(path, identity(2));
    EXPECT_EQ(old.estimate.size(), 30u);
  }
  core::commitStagedFile(path);
  const SavedGraph recovered = loadGraph(path, identity(2));
  EXPECT_EQ(recovered.estimate.size(), 40u);
  EXPECT_TRUE(recovered.has_state);
}

TEST(GraphIo, WriteErrorsAndNonFiniteValuesFailTheSave) {
  SavedGraph g = sampleGraph(2);
  EXPECT_THROW(saveGraph(g, "/dev/full"), std::runtime_error);
  EXPECT_THROW(saveGraph(g, tempDir() + "/no_such_dir/x.g2o"), std::runtime_error);
  const std::string path = tempDir() + "/nan.g2o";
  saveGraph(g, path);
  const std::string before = readFile(path);
  g.loops[0].score = std::nan("");
  EXPECT_THROW(saveGraph(g, path), std::invalid_argument);
  g = sampleGraph(2);
  g.estimate[3].translation.y() = std::numeric_limits<double>::infinity();
  EXPECT_THROW(saveGraph(g, path), std::invalid_argument);
  EXPECT_EQ(readFile(path), before) << "a failed save leaves the previous one";
  EXPECT_NO_THROW(loadGraph(path, identity(2)));
}

}  // namespace
}  // namespace ros_backend
}  // namespace agnc_pgo
