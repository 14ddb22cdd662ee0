// Regression tests for hostile or damaged input to the core readers and
// writers (g2o, .irl, TUM): every case names file:line:reason, nothing
// non-finite or absurd gets through, a truncated save is refused, a write
// error is an error, and save -> load -> save is byte-identical.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <random>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "agnc_pgo/core/atomic_file.h"
#include "agnc_pgo/core/g2o_io.h"
#include "agnc_pgo/eval/irl_io.h"
#include "agnc_pgo/eval/metrics.h"
#include "shared_datasets.h"

namespace agnc_pgo {
namespace core {
namespace {

std::string dataset(const std::string& file) { return std::string(AGNC_PGO_SHARED_DIR) + "/datasets/" + file; }

PoseGraph readG2oString(const std::string& text) {
  std::istringstream in(text);
  return readG2o(in, "f.g2o");
}

IncrementalLog readIrlString(const std::string& text) {
  std::istringstream in(text);
  return readIrl(in, "f.irl");
}

template <typename Read>
void expectError(Read read, const std::string& text, const std::string& prefix, const std::string& reason) {
  try {
    read(text);
    ADD_FAILURE() << "accepted: " << text.substr(0, 200);
  } catch (const std::exception& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.substr(0, prefix.size()), prefix) << what;
    EXPECT_NE(what.find(reason), std::string::npos) << what;
    EXPECT_LT(what.size(), 300u) << "error messages quote a bounded prefix of a token";
  }
}

void expectG2oError(const std::string& text, int line, const std::string& reason) {
  expectError(readG2oString, text, "f.g2o:" + std::to_string(line) + ": ", reason);
}

const std::string kTwoVertices = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n";
const std::string kInfo2 = " 1 0 0 1 0 1";

TEST(ReaderHardening, G2oRejectsAbsurdTranslations) {
  expectG2oError("VERTEX_SE2 0 1e308 0 0\n", 1, "implausible magnitude '1e308'");
  expectG2oError(kTwoVertices + "EDGE_SE2 0 1 1e308 0 0" + kInfo2 + "\n", 3, "implausible magnitude");
  expectG2oError("VERTEX_SE3:QUAT 0 0 -2e9 0 0 0 0 1\n", 1, "implausible magnitude");
}

TEST(ReaderHardening, G2oRejectsAbsurdInformation) {
  expectG2oError(kTwoVertices + "EDGE_SE2 0 1 1 0 0 1e308 0 0 1 0 1\n", 3, "implausible information entry");
}

TEST(ReaderHardening, G2oRejectsQuaternionsWhoseNormOverflows) {
  expectG2oError("VERTEX_SE3:QUAT 0 0 0 0 1e154 0 0 1\n", 1, "quaternion norm is implausibly large");
  expectG2oError("VERTEX_SE3:QUAT 0 0 0 0 1e200 1e200 0 0\n", 1, "quaternion norm is implausibly large");
}

TEST(ReaderHardening, G2oRejectsEmbeddedNulBytes) {
  std::string text = "VERTEX_SE2 0 1.5";
  text += '\0';
  text += "junk 0 0\n";
  expectG2oError(text, 1, "'1.5\\x00junk' is not a number");
}

TEST(ReaderHardening, G2oQuotesABoundedPrefixOfAHugeToken) {
  const std::string huge(1 << 20, '7');
  expectG2oError("VERTEX_SE2 0 x" + huge + " 0 0\n", 1, "(1048577 bytes, truncated) is not a number");
  expectG2oError("X" + huge + " 1\n", 1, "unknown tag 'X777");
}

TEST(ReaderHardening, EmptyG2oIsAReaderError) {
  expectG2oError("", 1, "no vertices and no edges");
  expectG2oError("# only a comment\n\n", 2, "no vertices and no edges");
}

TEST(ReaderHardening, EdgesOnlyG2oWhoseOdometryComposesBeyondBoundsIsRefused) {
  std::ostringstream text;
  for (int k = 0; k < 3; ++k) text << "EDGE_SE2 " << k << ' ' << k + 1 << " 9e8 0 0" << kInfo2 << "\n";
  expectG2oError(text.str(), 2, "composing the odometry puts pose 2 at an implausible position");
}

TEST(ReaderHardening, IrlRejectsAbsurdValuesAndTinyCovariance) {
  const std::string header = "t\nd\n2\nnonlinear\nn\nPRIOR 1 0 0 0 0 0 0.1 0 0 0 0.1 0 0 0 0.1\n";
  const auto expectIrlError = [](const std::string& text, int line, const std::string& reason) {
    expectError(readIrlString, text, "f.irl:" + std::to_string(line) + ": ", reason);
  };
  expectIrlError(header + "ODOMETRY 1 0 0 1 1e308 0 0 0.1 0 0 0 0.1 0 0 0 0.1\n", 7, "implausible magnitude");
  expectIrlError(header + "ODOMETRY 1 0 0 1 1 0 0 1e-320 0 0 0 0.1 0 0 0 0.1\n", 7, "covariance is too small");
  expectIrlError(header + "ODOMETRY 1 0 0 1 1 0 0 1e-18 0 0 0 0.1 0 0 0 0.1\n", 7, "covariance is too small");
  std::string nul = header + "ODOMETRY 1 0 0 1 1";
  nul += '\0';
  nul += "5 0 0 0.1 0 0 0 0.1 0 0 0 0.1\n";
  expectIrlError(nul, 7, "is not a number");
}

// A graph as an optimiser leaves it: headings whose quaternions no angle
// reproduces exactly (products of rotations), arbitrary translations.
PoseGraph solvedLooking2D() {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uniform(-3.0, 3.0);
  PoseGraph g;
  g.dimension = 2;
  Pose pose;
  for (int i = 0; i < 400; ++i) {
    g.poses.push_back(pose);
    pose = pose * Pose::fromSE2(uniform(rng), uniform(rng), uniform(rng));
  }
  for (int i = 0; i + 1 < 400; ++i) {
    Edge e;
    e.from = i;
    e.to = i + 1;
    e.measurement = g.poses[i].inverse() * g.poses[i + 1];
    e.information = Eigen::Matrix3d::Identity() * 1.0 / 3.0;
    e.kind = EdgeKind::kOdometry;
    g.edges.push_back(e);
  }
  g.fixed = {0};
  return g;
}

std::string toText(const PoseGraph& g) {
  std::ostringstream out;
  writeG2o(g, out);
  return out.str();
}

TEST(ReaderHardening, SaveLoadSaveIsByteIdentical2D) {
  const std::string first = toText(solvedLooking2D());
  const std::string second = toText(readG2oString(first));
  EXPECT_EQ(first, second);
  EXPECT_EQ(second, toText(readG2oString(second)));
}

TEST(ReaderHardening, SaveLoadSaveIsByteIdentical3D) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  PoseGraph g = readG2o(dataset("sphere2500.g2o"));
  // Products of quaternions, as an optimiser's estimate would hold.
  for (size_t i = 1; i < g.poses.size(); ++i) g.poses[i] = g.poses[i - 1] * (g.poses[i - 1].inverse() * g.poses[i]);
  const std::string first = toText(g);
  const std::string second = toText(readG2oString(first));
  EXPECT_EQ(first, second);
}

TEST(ReaderHardening, SavedG2oAnnouncesItsCountsAndTruncationIsRefused) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  const std::string text = toText(readG2o(dataset("csail.g2o")));
  EXPECT_EQ(text.substr(0, 50), "# agnc_pgo_g2o vertices 1045 edges 1172 fix 0\nVERT");
  // Cut at a line end in the edge section, and inside the last number.
  const size_t edges_line = text.rfind("EDGE_SE2");
  expectG2oError(text.substr(0, edges_line), 2217, "file is truncated");
  const size_t end_line = text.rfind("# agnc_pgo_g2o end");
  expectG2oError(text.substr(0, end_line - 2), 2218, "file is truncated");
  // A line dropped in the middle (counts no longer match).
  std::string dropped = text;
  const size_t vertex = dropped.find("VERTEX_SE2 7 ");
  dropped.erase(vertex, dropped.find('\n', vertex) + 1 - vertex);
  EXPECT_THROW(readG2oString(dropped), std::runtime_error);
  EXPECT_EQ(readG2oString(text).poses.size(), 1045u);
}

TEST(ReaderHardening, WriterRefusesNonFiniteValues) {
  PoseGraph g = solvedLooking2D();
  g.poses[3].translation.x() = std::numeric_limits<double>::infinity();
  std::ostringstream out;
  EXPECT_THROW(writeG2o(g, out), std::invalid_argument);
  Poses poses(3);
  poses[1].translation.y() = std::nan("");
  EXPECT_THROW(writeTumTrajectory(poses, testing::TempDir() + "agnc_pgo_nan.tum"), std::invalid_argument);
}

TEST(ReaderHardening, WriteErrorsAreReported) {
  const Poses poses(3);
  try {
    writeTumTrajectory(poses, "/dev/full");
    ADD_FAILURE() << "a write to /dev/full succeeded";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("No space left on device"), std::string::npos) << e.what();
  }
  EXPECT_THROW(writeG2o(solvedLooking2D(), std::string("/dev/full")), std::runtime_error);
  EXPECT_THROW(writeFileAtomically("/dev/full", "x"), std::runtime_error);
}

TEST(ReaderHardening, AtomicWriteReplacesAndLeavesNoTemporary) {
  const std::string dir = testing::TempDir() + "agnc_pgo_atomic_" + std::to_string(::getpid());
  ASSERT_EQ(std::system(("rm -rf '" + dir + "' && mkdir -p '" + dir + "'").c_str()), 0);
  const std::string path = dir + "/file.txt";
  writeFileAtomically(path, "old\n");
  writeFileAtomically(path, "new content\n");
  EXPECT_EQ(readWholeFile(path, 100), "new content\n");
  EXPECT_THROW(readWholeFile(path, 5), std::runtime_error);
  const std::string listing = dir + ".listing";
  ASSERT_EQ(std::system(("ls '" + dir + "' > '" + listing + "'").c_str()), 0);
  EXPECT_EQ(readWholeFile(listing, 1000), "file.txt\n");
  stageFile(path, "staged\n");
  EXPECT_EQ(readWholeFile(path, 100), "new content\n") << "staging leaves the old file in place";
  commitStagedFile(path);
  EXPECT_EQ(readWholeFile(path, 100), "staged\n");
  EXPECT_EQ(crc32Of("123456789"), 0xCBF43926ul);  // the CRC-32 check value
  std::system(("rm -rf '" + dir + "' '" + listing + "'").c_str());
}

}  // namespace
}  // namespace core
}  // namespace agnc_pgo
