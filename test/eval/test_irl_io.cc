#include "agnc_pgo/eval/irl_io.h"

#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "shared_datasets.h"

namespace agnc_pgo {
namespace core {
namespace {

std::string irl(const std::string& file) {
  return std::string(AGNC_PGO_SHARED_DIR) + "/irl/" + file;
}

IncrementalLog readString(const std::string& text, const std::string& name = "inline.irl") {
  std::istringstream in(text);
  return readIrl(in, name);
}

const char kHeader2D[] = "test\n2026-01-01\n2\nnonlinear\nnotes\n";
const char kHeader3D[] = "test3\n2026-01-01\n3\nnonlinear\nnotes\n";
const char kPrior2D[] = "PRIOR 1 0 0 0 0 0 0.1 0 0 0 0.1 0 0 0 0.1\n";  // line 6
const char kOdometry2D[] = "ODOMETRY 1 0 0 1 1 0 0 0.1 0 0 0 0.1 0 0 0 0.1\n";  // line 7
const char kCov3D[] = " 1 0 0 0 0 0 0 2 0 0 0 0 0 0 3 0 0 0 0 0 0 4 0 0 0 0 0 0 5 0 0 0 0 0 0 6";

int countEntries(const IncrementalLog& log, EntryType type) {
  int n = 0;
  for (const LogEntry& e : log.entries) n += e.type == type;
  return n;
}

TEST(IrlIo, ReadsCsailWithOutliers) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  const IncrementalLog log = readIrl(irl("CSAIL_10_random_0.irl"));
  EXPECT_EQ(log.name, "CSAIL_10_random_0");
  EXPECT_EQ(log.dimension, 2);
  EXPECT_EQ(log.numPoses(), 1045);
  EXPECT_EQ(log.numLoopClosures(), 142);
  EXPECT_EQ(log.numOutliers(), 14);
  EXPECT_EQ(countEntries(log, EntryType::kPrior), 1);
  EXPECT_EQ(countEntries(log, EntryType::kOdometry), 1044);
  ASSERT_EQ(log.entries.size(), 1u + 1044u + 142u);

  // "PRIOR 1 0 0 0.00000 0.00000 0.00000 0.1 0.0 0.0 0.0 0.1 0.0 0.0 0.0 0.1"
  const LogEntry& prior = log.entries[0];
  EXPECT_EQ(prior.type, EntryType::kPrior);
  EXPECT_EQ(prior.edge.to, 0);
  EXPECT_LT((prior.edge.information - 10.0 * Eigen::Matrix3d::Identity()).norm(), 1e-9);

  // "ODOMETRY 1 0 0 1 0.08276 0.00305 0.28402 <cov>": information = cov^-1.
  const Edge& odom = log.entries[1].edge;
  EXPECT_EQ(log.entries[1].type, EntryType::kOdometry);
  EXPECT_EQ(odom.from, 0);
  EXPECT_EQ(odom.to, 1);
  EXPECT_EQ(odom.kind, EdgeKind::kOdometry);
  EXPECT_EQ(odom.measurement.translation, Eigen::Vector3d(0.08276, 0.00305, 0.0));
  EXPECT_NEAR(odom.measurement.yaw(), 0.28402, 1e-12);
  Eigen::Matrix3d cov;
  cov << 0.022469505719692657, 0.0008274492053994593, -0.0, 0.0008274492053994594,
      4.764074293744146e-05, 0.0, 0.0, 0.0, 0.00016487073603164043;
  EXPECT_LT((odom.information * cov - Eigen::Matrix3d::Identity()).norm(), 1e-9);
  EXPECT_EQ(odom.information, odom.information.transpose());

  // Every outlier is the identity pose with covariance diag(0.015, 0.01, 0.001).
  for (const LogEntry& e : log.entries) {
    if (e.type != EntryType::kLoopClosure) continue;
    EXPECT_EQ(e.edge.kind, EdgeKind::kLoopClosure);
    if (!e.edge.is_outlier) continue;
    EXPECT_EQ(e.edge.measurement.translation.norm(), 0.0);
    EXPECT_EQ(e.edge.measurement.yaw(), 0.0);
    EXPECT_NEAR(e.edge.information(0, 0), 1 / 0.015, 1e-9);
    EXPECT_NEAR(e.edge.information(1, 1), 1 / 0.01, 1e-9);
    EXPECT_NEAR(e.edge.information(2, 2), 1 / 0.001, 1e-9);
  }
  // The first loop is "LOOP 2 0 119 23 2.30374 -1.95233 1.55790 ..." (true,
  // written newer -> older).
  const LogEntry* first_loop = nullptr;
  for (const LogEntry& e : log.entries) {
    if (e.type == EntryType::kLoopClosure) {
      first_loop = &e;
      break;
    }
  }
  ASSERT_NE(first_loop, nullptr);
  EXPECT_EQ(first_loop->edge.from, 119);
  EXPECT_EQ(first_loop->edge.to, 23);
  EXPECT_FALSE(first_loop->edge.is_outlier);
  EXPECT_EQ(first_loop->edge.measurement.translation, Eigen::Vector3d(2.30374, -1.95233, 0.0));
  EXPECT_NEAR(first_loop->edge.measurement.yaw(), 1.55790, 1e-12);
}

TEST(IrlIo, ReadsIntelWithOutliers) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  const IncrementalLog log = readIrl(irl("INTEL_10_random_0.irl"));
  EXPECT_EQ(log.dimension, 2);
  EXPECT_EQ(log.numPoses(), 943);
  EXPECT_EQ(log.numLoopClosures(), 994);
  EXPECT_EQ(log.numOutliers(), 99);
}

TEST(IrlIo, ReadsSphere2500In3DWithPermutedCovariance) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  const IncrementalLog log = readIrl(irl("SPHERE2500_10_random_0.irl"));
  EXPECT_EQ(log.dimension, 3);
  EXPECT_EQ(log.numPoses(), 2500);
  EXPECT_EQ(log.numLoopClosures(), 2722);
  EXPECT_EQ(log.numOutliers(), 272);
  // Outlier covariance (rotation first) is diag(0.0025 x3, 0.1 x3): in g2o
  // order the translation information is 10 and the rotation one 400.
  int outliers_checked = 0;
  for (const LogEntry& e : log.entries) {
    if (e.type != EntryType::kLoopClosure || !e.edge.is_outlier) continue;
    ASSERT_EQ(e.edge.information.rows(), 6);
    Eigen::VectorXd expected(6);
    expected << 10, 10, 10, 400, 400, 400;
    EXPECT_LT((e.edge.information.diagonal() - expected).norm(), 1e-9);
    ++outliers_checked;
  }
  EXPECT_EQ(outliers_checked, 272);

  // Line 58 "LOOP 2 0 50 0 ...": read by the format's definition, the file's
  // trailing 3x3 block (0.0025...) is the translation covariance, which is
  // the top-left block in g2o order (shared/irl/README.md on the swap).
  const LogEntry* first_loop = nullptr;
  for (const LogEntry& e : log.entries) {
    if (e.type == EntryType::kLoopClosure) {
      first_loop = &e;
      break;
    }
  }
  ASSERT_NE(first_loop, nullptr);
  EXPECT_EQ(first_loop->edge.from, 50);
  EXPECT_EQ(first_loop->edge.to, 0);
  const Eigen::MatrixXd cov = first_loop->edge.information.inverse();
  EXPECT_NEAR(cov(0, 0), 0.002501997178794502, 1e-15);
  EXPECT_NEAR(cov(0, 2), 7.267827916879507e-05, 1e-15);
  EXPECT_NEAR(cov(2, 2), 0.010012351676249698, 1e-15);
  EXPECT_NEAR(cov(3, 3), 0.1, 1e-15);
  EXPECT_NEAR(cov(0, 3), 0.0, 1e-15);
  // "ODOMETRY 1 0 0 1 0.34190 -0.04170 0.03304 -0.00306 0.00822 0.18020 ..."
  const Edge& odom = log.entries[1].edge;
  const Pose expected = Pose::fromXYZRPY(0.34190, -0.04170, 0.03304, -0.00306, 0.00822, 0.18020);
  EXPECT_EQ(odom.measurement.translation, expected.translation);
  EXPECT_LT(odom.measurement.rotation.angularDistance(expected.rotation), 1e-15);
}

TEST(IrlIo, PermutesRotationFirstCovarianceToG2oOrder) {
  const std::string text = std::string(kHeader3D) + "PRIOR 1 0 0 0 0 0 0 0 0" + kCov3D + "\n" +
                           "ODOMETRY 1 0 0 1 1 2 3 0.1 0.2 0.3" + kCov3D + "\n";
  const IncrementalLog log = readString(text);
  ASSERT_EQ(log.entries.size(), 2u);
  Eigen::VectorXd expected(6);
  expected << 1.0 / 4, 1.0 / 5, 1.0 / 6, 1.0, 1.0 / 2, 1.0 / 3;
  for (const LogEntry& e : log.entries) {
    EXPECT_LT((e.edge.information.diagonal() - expected).norm(), 1e-15);
    EXPECT_EQ(e.edge.information.norm(), e.edge.information.diagonal().norm());  // still diagonal
  }
  const Pose z = log.entries[1].edge.measurement;
  const Pose expected_pose = Pose::fromXYZRPY(1, 2, 3, 0.1, 0.2, 0.3);
  EXPECT_EQ(z.translation, expected_pose.translation);
  EXPECT_LT(z.rotation.angularDistance(expected_pose.rotation), 1e-15);

  // A coupling between rx (file index 0) and x (file index 3) lands at g2o (3, 0).
  const std::string coupled = std::string(kHeader3D) +
                              "PRIOR 1 0 0 0 0 0 0 0 0"
                              " 2 0 0 1 0 0  0 2 0 0 0 0  0 0 2 0 0 0"
                              " 1 0 0 3 0 0  0 0 0 0 3 0  0 0 0 0 0 3\n";
  const Eigen::MatrixXd cov = readString(coupled).entries[0].edge.information.inverse();
  EXPECT_NEAR(cov(0, 0), 3.0, 1e-12);
  EXPECT_NEAR(cov(3, 3), 2.0, 1e-12);
  EXPECT_NEAR(cov(3, 0), 1.0, 1e-12);
  EXPECT_NEAR(cov(0, 3), 1.0, 1e-12);
  EXPECT_NEAR(cov(0, 1), 0.0, 1e-12);
}

void expectParseError(const std::string& text, int line, const std::string& reason) {
  const std::string name = "bad_fixture.irl";
  try {
    readString(text, name);
    ADD_FAILURE() << "no ParseError for:\n" << text;
  } catch (const ParseError& e) {
    EXPECT_EQ(e.file(), name);
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_NE(e.reason().find(reason), std::string::npos) << e.what();
    const std::string prefix = name + ":" + std::to_string(line) + ": ";
    EXPECT_EQ(std::string(e.what()).substr(0, prefix.size()), prefix) << e.what();
  }
}

TEST(IrlIo, AcceptsTheInlineFixtureBase) {
  // The malformed cases below each break one thing in this valid log.
  const IncrementalLog log = readString(std::string(kHeader2D) + kPrior2D + kOdometry2D +
                                        "ODOMETRY 1 0 1 2 1 0 0 0.1 0 0 0 0.1 0 0 0 0.1\n"
                                        "LOOP 2 1 2 0 0 0 0 0.1 0 0 0 0.1 0 0 0 0.1 NULL\n");
  EXPECT_EQ(log.numPoses(), 3);
  EXPECT_EQ(log.numLoopClosures(), 1);
  EXPECT_EQ(log.numOutliers(), 1);
}

// Header and prior (lines 1-6) followed by `entries` from line 7 on.
std::string log2D(const std::string& entries) {
  return std::string(kHeader2D) + kPrior2D + entries;
}

TEST(IrlIo, RejectsBadTokenCount) {
  // Missing the last covariance entry.
  expectParseError(log2D("ODOMETRY 1 0 0 1 1 0 0 0.1 0 0 0 0.1 0 0 0\n"), 7, "too few values");
  // One value too many.
  expectParseError(log2D("ODOMETRY 1 0 0 1 1 0 0 0.1 0 0 0 0.1 0 0 0 0.1 7\n"), 7,
                   "too many values");
  // A LOOP announcing two modes but giving only one.
  expectParseError(log2D(std::string(kOdometry2D) +
                         "ODOMETRY 1 0 1 2 1 0 0 0.1 0 0 0 0.1 0 0 0 0.1\n"
                         "LOOP 2 0 2 0 0 0 0 0.1 0 0 0 0.1 0 0 0 0.1\n"),
                   9, "too few values");
}

TEST(IrlIo, RejectsNonNumbersAndNan) {
  expectParseError(log2D("ODOMETRY 1 0 0 1 nan 0 0 0.1 0 0 0 0.1 0 0 0 0.1\n"), 7,
                   "non-finite value 'nan'");
  expectParseError(log2D("ODOMETRY 1 0 0 1 1 0 0 0.1 0 0 0 inf 0 0 0 0.1\n"), 7,
                   "non-finite value 'inf'");
  expectParseError(log2D("ODOMETRY 1 0 0 1 1 0 0 0.1 0 0 0 0.1 0 0 0 0.1x\n"), 7,
                   "'0.1x' is not a number");
  expectParseError(log2D("ODOMETRY 1 0 0.5 1 1 0 0 0.1 0 0 0 0.1 0 0 0 0.1\n"), 7,
                   "'0.5' is not an integer");
}

TEST(IrlIo, RejectsNonPositiveDefiniteCovariance) {
  expectParseError(log2D("ODOMETRY 1 0 0 1 1 0 0 0.1 0 0 0 0 0 0 0 0.1\n"), 7,
                   "covariance is not positive definite");
  expectParseError(log2D("ODOMETRY 1 0 0 1 1 0 0 0.1 0.2 0 0.2 0.1 0 0 0 0.1\n"), 7,
                   "covariance is not positive definite");
  expectParseError(std::string(kHeader3D) +
                       "PRIOR 1 0 0 0 0 0 0 0 0"
                       " 1 0 0 0 0 0  0 2 0 0 0 0  0 0 3 0 0 0"
                       " 0 0 0 -4 0 0  0 0 0 0 5 0  0 0 0 0 0 6\n",
                   6, "covariance is not positive definite");
}

TEST(IrlIo, RejectsBadHeader) {
  expectParseError("test\n2026-01-01\n4\nnonlinear\nnotes\n", 3,
                   "dimension must be 2 or 3, got '4'");
  expectParseError("test\n2026-01-01\ntwo\nnonlinear\nnotes\n", 3, "dimension must be 2 or 3");
  expectParseError("test\n2026-01-01\n2\nlinear\nnotes\n", 4, "expected 'nonlinear'");
  expectParseError("test\n2026-01-01\n", 3, "file ends inside the 5-line header");
}

TEST(IrlIo, RejectsUnsupportedShapes) {
  // Poses 0..2 exist after line 8.
  const std::string base = log2D(std::string(kOdometry2D) +
                                 "ODOMETRY 1 0 1 2 1 0 0 0.1 0 0 0 0.1 0 0 0 0.1\n");
  const std::string cov = " 0.1 0 0 0 0.1 0 0 0 0.1";
  const std::string mode = " 0 1 0 0" + cov;
  expectParseError(base + "LOOP 2 0 2" + mode + mode + "\n", 9, "more than one non-NULL mode");
  expectParseError(base + "LOOP 2 0 2 NULL NULL\n", 9, "no non-NULL mode");
  expectParseError(base + "LOOP 0 0 2\n", 9, "at least 1 mode");
  expectParseError(base + "LANDMARK 1 0 2\n", 9, "unknown entry type 'LANDMARK'");
  expectParseError(base + "ODOMETRY 1 0 2 4 1 0 0" + cov + "\n", 9, "must join pose i to i+1");
  expectParseError(base + "ODOMETRY 2 0 2 3 1 0 0" + cov + "\n", 9, "exactly 1 mode");
  expectParseError(base + "LOOP 2 0 2 5 1 0 0" + cov + " NULL\n", 9, "pose 5 does not exist yet");
}

TEST(IrlIo, MissingFileNamesTheFile) {
  const std::string path = irl("missing.irl");
  try {
    readIrl(path);
    FAIL() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

TEST(IrlIo, GraphFromIrlLogKeepsLabels) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  const PoseGraph g = graphFromLog(readIrl(irl("CSAIL_10_random_0.irl")));
  EXPECT_EQ(g.dimension, 2);
  EXPECT_EQ(g.poses.size(), 1045u);
  EXPECT_EQ(g.edges.size(), 1044u + 142u);
  EXPECT_EQ(g.numLoopClosures(), 142);
  EXPECT_EQ(g.numOutliers(), 14);
  // Poses are composed odometry: pose 1 is the first odometry measurement.
  EXPECT_LT((g.poses[1].translation - Eigen::Vector3d(0.08276, 0.00305, 0)).norm(), 1e-15);
}

}  // namespace
}  // namespace core
}  // namespace agnc_pgo
