#include "agnc_pgo/core/g2o_io.h"

#include <cstdio>
#include <fstream>
#include <iomanip>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "shared_datasets.h"

namespace agnc_pgo {
namespace core {
namespace {

std::string dataset(const std::string& file) {
  return std::string(AGNC_PGO_SHARED_DIR) + "/datasets/" + file;
}

PoseGraph readString(const std::string& text, const std::string& name = "inline.g2o") {
  std::istringstream in(text);
  return readG2o(in, name);
}

// Counts from shared/datasets/README.md.
struct DatasetCounts {
  const char* file;
  int dimension;
  int poses;
  int odometry;
  int loops;
  int loops_backwards;  // loops written i > j
};

TEST(G2oIo, ReadsEverySharedDatasetWithDocumentedCounts) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  const std::vector<DatasetCounts> datasets = {
      {"csail.g2o", 2, 1045, 1044, 128, 0},
      {"intel.g2o", 2, 943, 942, 895, 0},
      {"manhattanOlson3500.g2o", 2, 3500, 3499, 2099, 0},
      {"sphere2500.g2o", 3, 2500, 2499, 2450, 0},
      {"noisyToyGraph.g2o", 2, 4, 3, 2, 1},
      {"pose2example.g2o", 2, 11, 10, 2, 0},
      {"pose3example.g2o", 3, 5, 4, 2, 1},
      {"pose3example_offdiagonal.g2o", 3, 2, 1, 0, 0},
      {"tinyGrid3D.g2o", 3, 9, 8, 3, 1},
      {"smallGrid3D.g2o", 3, 125, 124, 173, 33},
      {"ring.g2o", 2, 434, 433, 26, 26},
  };
  for (const DatasetCounts& d : datasets) {
    SCOPED_TRACE(d.file);
    const PoseGraph g = readG2o(dataset(d.file));
    EXPECT_EQ(g.dimension, d.dimension);
    EXPECT_EQ(static_cast<int>(g.poses.size()), d.poses);
    EXPECT_EQ(g.numLoopClosures(), d.loops);
    EXPECT_EQ(static_cast<int>(g.edges.size()) - g.numLoopClosures(), d.odometry);
    EXPECT_EQ(g.numOutliers(), 0);
    EXPECT_TRUE(g.fixed.empty());
    int backwards = 0;
    for (const Edge& e : g.edges) {
      ASSERT_EQ(e.information.rows(), g.tangentDimension());
      ASSERT_EQ(e.information.cols(), g.tangentDimension());
      EXPECT_EQ(e.kind, classifyEdge(e.from, e.to));
      if (e.kind == EdgeKind::kLoopClosure && e.from > e.to) ++backwards;
    }
    EXPECT_EQ(backwards, d.loops_backwards);
    for (const Pose& p : g.poses) EXPECT_NEAR(p.rotation.norm(), 1.0, 1e-15);
  }
}

TEST(G2oIo, ReadsValuesOfFirstLines) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  const PoseGraph g = readG2o(dataset("ring.g2o"));
  // "VERTEX_SE2 2 1.937515 -0.000470 6.282233": heading wraps to the same rotation.
  EXPECT_EQ(g.poses[2].translation, Eigen::Vector3d(1.937515, -0.000470, 0.0));
  EXPECT_NEAR(g.poses[2].yaw(), 6.282233 - 2 * M_PI, 1e-12);

  const PoseGraph p3 = readG2o(dataset("pose3example_offdiagonal.g2o"));
  const Pose& v1 = p3.poses[1];
  EXPECT_EQ(v1.translation, Eigen::Vector3d(1.001367, 0.015390, 0.004948));
  const Eigen::Vector4d q(0.190253, 0.283162, -0.392318, 0.854230);  // x y z w as in the file
  EXPECT_LT((v1.rotation.coeffs() - q.normalized()).norm(), 1e-15);
}

TEST(G2oIo, OffDiagonalInformationLandsInBothTriangles) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  // Row r of the upper triangle holds 10000 on the diagonal and r+1 after it.
  const PoseGraph g = readG2o(dataset("pose3example_offdiagonal.g2o"));
  ASSERT_EQ(g.edges.size(), 1u);
  const Eigen::MatrixXd& info = g.edges[0].information;
  for (int r = 0; r < 6; ++r) {
    EXPECT_EQ(info(r, r), 10000.0);
    for (int c = r + 1; c < 6; ++c) {
      EXPECT_EQ(info(r, c), r + 1.0) << r << "," << c;
      EXPECT_EQ(info(c, r), r + 1.0) << c << "," << r;
    }
  }
}

void expectParseError(const std::string& text, int line, const std::string& reason) {
  const std::string name = "bad_fixture.g2o";
  try {
    readString(text, name);
    ADD_FAILURE() << "no ParseError for: " << text;
  } catch (const ParseError& e) {
    EXPECT_EQ(e.file(), name);
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_NE(e.reason().find(reason), std::string::npos) << e.what();
    const std::string prefix = name + ":" + std::to_string(line) + ": ";
    EXPECT_EQ(std::string(e.what()).substr(0, prefix.size()), prefix) << e.what();
    EXPECT_NE(std::string(e.what()).find(reason), std::string::npos) << e.what();
  }
}

const char kTwoVertices[] =
    "# comment\n"
    "\n"
    "VERTEX_SE2 0 0 0 0\n"
    "VERTEX_SE2 1 1 0 0\n";  // edges after this are on line 5

TEST(G2oIo, RejectsBadTokenCount) {
  expectParseError("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0\n", 2, "expects 4 values, got 3");
  expectParseError(std::string(kTwoVertices) + "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1 7\n", 5,
                   "expects 11 values, got 12");
  expectParseError("VERTEX_SE3:QUAT 0 0 0 0 0 0 0\n", 1, "expects 8 values, got 7");
  expectParseError("FIX\n", 1, "FIX expects at least one id");
}

TEST(G2oIo, RejectsNonNumbers) {
  expectParseError(std::string(kTwoVertices) + "EDGE_SE2 0 1 1.0x 0 0 1 0 0 1 0 1\n", 5,
                   "'1.0x' is not a number");
  expectParseError("VERTEX_SE2 0 abc 0 0\n", 1, "'abc' is not a number");
  expectParseError("VERTEX_SE2 1.5 0 0 0\n", 1, "not an integer id");
  expectParseError("VERTEX_SE2 -1 0 0 0\n", 1, "negative id");
}

TEST(G2oIo, RejectsNanAndInf) {
  expectParseError("VERTEX_SE2 0 nan 0 0\n", 1, "non-finite value 'nan'");
  expectParseError(std::string(kTwoVertices) + "EDGE_SE2 0 1 1 0 0 inf 0 0 1 0 1\n", 5,
                   "non-finite value 'inf'");
  expectParseError("VERTEX_SE2 0 1e999 0 0\n", 1, "non-finite");
}

TEST(G2oIo, RejectsUnknownVertexInEdge) {
  // The edge comes first, so the id check must wait for the whole file but
  // still name the edge's line.
  expectParseError("EDGE_SE2 0 2 1 0 0 1 0 0 1 0 1\nVERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n", 1,
                   "unknown vertex 2");
}

TEST(G2oIo, RejectsNonPositiveDefiniteInformation) {
  expectParseError(std::string(kTwoVertices) + "EDGE_SE2 0 1 1 0 0 1 0 0 -1 0 1\n", 5,
                   "not positive definite");
  // Positive diagonal, but |I12| > sqrt(I11 I22): indefinite.
  expectParseError(std::string(kTwoVertices) + "EDGE_SE2 0 1 1 0 0 1 2 0 1 0 1\n", 5,
                   "not positive definite");
  expectParseError(
      "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT 1 1 0 0 0 0 0 1\n"
      "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1  1 0 0 0 0 0  1 0 0 0 0  1 0 0 0  0 0 0  1 0  1\n",
      3, "not positive definite");
}

TEST(G2oIo, RejectsDuplicateVertex) {
  expectParseError(std::string(kTwoVertices) + "VERTEX_SE2 1 2 0 0\n", 5,
                   "duplicate vertex 1 (first defined on line 4)");
}

TEST(G2oIo, RejectsMixed2DAnd3D) {
  expectParseError(std::string(kTwoVertices) + "VERTEX_SE3:QUAT 2 0 0 0 0 0 0 1\n", 5,
                   "mixed 2D and 3D");
}

TEST(G2oIo, RejectsUnknownTag) {
  expectParseError(std::string(kTwoVertices) + "VERTEX_XY 2 0 0\n", 5, "unknown tag 'VERTEX_XY'");
}

TEST(G2oIo, RejectsZeroQuaternion) {
  expectParseError("VERTEX_SE3:QUAT 0 0 0 0 0 0 0 0\n", 1, "quaternion has zero norm");
}

void expectGraphsIdentical(const PoseGraph& a, const PoseGraph& b);  // below

// Ids that skip values (ETHCampus skips 1432-1439): the poses are the ids in
// increasing order, the edges follow them, and the file's ids come back out.
constexpr const char* kGappedIds =
    "VERTEX_SE2 10 0 0 0\n"
    "VERTEX_SE2 14 2 0 0\n"  // before 11 in the file: order is by id
    "VERTEX_SE2 11 1 0 0\n"
    "VERTEX_SE2 20 3 0 0.5\n"
    "EDGE_SE2 10 11 1 0 0 1 0 0 1 0 1\n"
    "EDGE_SE2 11 14 1 0 0 1 0 0 1 0 1\n"
    "EDGE_SE2 14 20 1 0 0.5 1 0 0 1 0 1\n"
    "EDGE_SE2 20 10 -3 0 -0.5 1 0 0 1 0 1\n"
    "FIX 14\n";

TEST(G2oIo, NumbersSkippedIdsInOrderAndKeepsThem) {
  const PoseGraph g = readString(kGappedIds);
  ASSERT_EQ(g.poses.size(), 4u);
  EXPECT_EQ(g.file_ids, (std::vector<int>{10, 11, 14, 20}));
  EXPECT_DOUBLE_EQ(g.poses[1].translation.x(), 1.0);  // id 11
  EXPECT_DOUBLE_EQ(g.poses[2].translation.x(), 2.0);  // id 14
  EXPECT_NEAR(g.poses[3].yaw(), 0.5, 1e-15);          // id 20
  ASSERT_EQ(g.edges.size(), 4u);
  // Neighbours in id order are odometry however far apart their ids are.
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(g.edges[k].from, k);
    EXPECT_EQ(g.edges[k].to, k + 1);
    EXPECT_EQ(g.edges[k].kind, EdgeKind::kOdometry);
  }
  EXPECT_EQ(g.edges[3].from, 3);
  EXPECT_EQ(g.edges[3].to, 0);
  EXPECT_EQ(g.edges[3].kind, EdgeKind::kLoopClosure);
  EXPECT_EQ(g.fixed, (std::vector<int>{2}));
  EXPECT_EQ(g.fileId(3), 20);
}

TEST(G2oIo, WritesTheFileIdsBackExactly) {
  const PoseGraph g = readString(kGappedIds);
  std::ostringstream out;
  writeG2o(g, out);
  EXPECT_NE(out.str().find("VERTEX_SE2 20 3 0 0.5\n"), std::string::npos) << out.str();
  EXPECT_NE(out.str().find("EDGE_SE2 20 10 -3 0 -0.5 "), std::string::npos) << out.str();
  EXPECT_NE(out.str().find("FIX 14\n"), std::string::npos) << out.str();
  const PoseGraph back = readString(out.str());
  expectGraphsIdentical(g, back);
  EXPECT_EQ(back.file_ids, g.file_ids);
  std::ostringstream again;
  writeG2o(back, again);
  EXPECT_EQ(out.str(), again.str());
}

TEST(G2oIo, ContiguousIdsKeepNoFileIds) {
  EXPECT_TRUE(readString(kTwoVertices).file_ids.empty());
  // 1..n is not 0..n-1: kept.
  EXPECT_EQ(readString("VERTEX_SE2 1 0 0 0\nVERTEX_SE2 2 1 0 0\n").file_ids, (std::vector<int>{1, 2}));
}

TEST(G2oIo, EdgesOnlyWithSkippedIdsComposeTheChain) {
  // Ids 0, 1, 3: pose 2 is id 3, one step after id 1.
  const PoseGraph g = readString("EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\nEDGE_SE2 1 3 1 0 0 1 0 0 1 0 1\n");
  ASSERT_EQ(g.poses.size(), 3u);
  EXPECT_EQ(g.file_ids, (std::vector<int>{0, 1, 3}));
  EXPECT_DOUBLE_EQ(g.poses[2].translation.x(), 2.0);
  EXPECT_EQ(g.numLoopClosures(), 0);
}

TEST(G2oIo, WriterRefusesFileIdsThatWouldNotReadBack) {
  PoseGraph g = readString(kGappedIds);
  std::ostringstream out;
  g.file_ids = {10, 11, 11, 20};
  EXPECT_THROW(writeG2o(g, out), std::invalid_argument);
  g.file_ids = {10, 11, 14};
  EXPECT_THROW(writeG2o(g, out), std::invalid_argument);
}

TEST(G2oIo, RejectsFixOfUnknownVertex) {
  expectParseError(std::string(kTwoVertices) + "FIX 5\n", 5, "FIX references unknown vertex 5");
}

TEST(G2oIo, MissingFileNamesTheFile) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  const std::string path = dataset("does_not_exist.g2o");
  try {
    readG2o(path);
    FAIL() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

TEST(G2oIo, ReadsFixLinesAndCommentsAndCrLf) {
  const PoseGraph g = readString(
      "# header comment\r\n"
      "VERTEX_SE2 0 0 0 0\r\n"
      "   \r\n"
      "VERTEX_SE2 1 1 0 0\r\n"
      "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\r\n"
      "FIX 1\r\n");
  ASSERT_EQ(g.poses.size(), 2u);
  ASSERT_EQ(g.fixed.size(), 1u);
  EXPECT_EQ(g.fixed[0], 1);
  EXPECT_EQ(g.edges[0].kind, EdgeKind::kOdometry);
}

void expectGraphsIdentical(const PoseGraph& a, const PoseGraph& b) {
  ASSERT_EQ(a.dimension, b.dimension);
  ASSERT_EQ(a.poses.size(), b.poses.size());
  ASSERT_EQ(a.edges.size(), b.edges.size());
  EXPECT_EQ(a.fixed, b.fixed);
  for (size_t i = 0; i < a.poses.size(); ++i) {
    // Exact double equality: the text must carry every bit.
    ASSERT_TRUE(a.poses[i].translation == b.poses[i].translation) << "pose " << i;
    ASSERT_TRUE(a.poses[i].rotation.coeffs() == b.poses[i].rotation.coeffs()) << "pose " << i;
  }
  for (size_t i = 0; i < a.edges.size(); ++i) {
    const Edge& ea = a.edges[i];
    const Edge& eb = b.edges[i];
    ASSERT_EQ(ea.from, eb.from) << "edge " << i;
    ASSERT_EQ(ea.to, eb.to) << "edge " << i;
    ASSERT_EQ(ea.kind, eb.kind) << "edge " << i;
    ASSERT_TRUE(ea.measurement.translation == eb.measurement.translation) << "edge " << i;
    ASSERT_TRUE(ea.measurement.rotation.coeffs() == eb.measurement.rotation.coeffs())
        << "edge " << i;
    ASSERT_TRUE(ea.information == eb.information) << "edge " << i;
  }
}

TEST(G2oIo, WriteReadRoundTripIsExact2D) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  for (const char* file : {"csail.g2o", "ring.g2o", "intel.g2o"}) {
    SCOPED_TRACE(file);
    PoseGraph g = readG2o(dataset(file));
    g.fixed = {0, 3};
    std::ostringstream out;
    writeG2o(g, out);
    const PoseGraph back = readString(out.str());
    expectGraphsIdentical(g, back);
    // Writing again gives the same text.
    std::ostringstream again;
    writeG2o(back, again);
    EXPECT_EQ(out.str(), again.str());
  }
}

TEST(G2oIo, WriteReadRoundTripIsExact3D) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  for (const char* file : {"sphere2500.g2o", "pose3example_offdiagonal.g2o", "smallGrid3D.g2o"}) {
    SCOPED_TRACE(file);
    PoseGraph g = readG2o(dataset(file));
    g.fixed = {1};
    std::ostringstream out;
    writeG2o(g, out);
    expectGraphsIdentical(g, readString(out.str()));
  }
}

TEST(G2oIo, WriteToPathRoundTrips) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  const PoseGraph g = readG2o(dataset("tinyGrid3D.g2o"));
  const std::string path = testing::TempDir() + "agnc_pgo_test_g2o_io_roundtrip.g2o";
  writeG2o(g, path);
  expectGraphsIdentical(g, readG2o(path));
  std::remove(path.c_str());
  EXPECT_THROW(writeG2o(g, std::string("/nonexistent_dir/x.g2o")), std::runtime_error);
}

std::string edgeLine2D(int from, int to, const Pose& z) {
  std::ostringstream out;
  out << std::setprecision(17) << "EDGE_SE2 " << from << ' ' << to << ' ' << z.translation.x()
      << ' ' << z.translation.y() << ' ' << z.yaw() << " 2 0.5 0 3 0 4\n";
  return out.str();
}

TEST(G2oIo, EdgesOnlyFileIsInitialisedFromOdometry) {
  const Pose p[4] = {Pose::identity(), Pose::fromSE2(1, 0, M_PI / 2), Pose::fromSE2(1, 2, 3.0),
                     Pose::fromSE2(0, 2, -M_PI / 2)};
  // Odometry 1-2 is written backwards (2 -> 1); a loop closes 3 -> 0.
  const std::string text = edgeLine2D(0, 1, p[0].inverse() * p[1]) +
                           edgeLine2D(2, 1, p[2].inverse() * p[1]) +
                           edgeLine2D(3, 0, p[3].inverse() * p[0]) +
                           edgeLine2D(2, 3, p[2].inverse() * p[3]);
  const PoseGraph g = readString(text);
  ASSERT_EQ(g.poses.size(), 4u);
  EXPECT_EQ(g.dimension, 2);
  EXPECT_EQ(g.numLoopClosures(), 1);
  for (int k = 0; k < 4; ++k) {
    EXPECT_LT((g.poses[k].translation - p[k].translation).norm(), 1e-12) << k;
    EXPECT_NEAR(wrapAngle(g.poses[k].yaw() - p[k].yaw()), 0.0, 1e-12) << k;
  }
  EXPECT_EQ(g.edges[1].from, 2);  // kept as written
  EXPECT_EQ(g.edges[1].to, 1);
  EXPECT_EQ(g.edges[1].information(0, 1), 0.5);
  EXPECT_EQ(g.edges[1].information(1, 0), 0.5);
}

TEST(G2oIo, EdgesOnly3DMatchesComposedOdometry) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  // tinyGrid3D without its VERTEX lines.
  std::ifstream in(dataset("tinyGrid3D.g2o"));
  std::string line, edges_only;
  while (std::getline(in, line)) {
    if (line.rfind("EDGE", 0) == 0) edges_only += line + "\n";
  }
  const PoseGraph full = readG2o(dataset("tinyGrid3D.g2o"));
  const PoseGraph g = readString(edges_only);
  ASSERT_EQ(g.poses.size(), full.poses.size());
  EXPECT_EQ(g.dimension, 3);
  EXPECT_EQ(g.edges.size(), full.edges.size());
  Pose expected = Pose::identity();
  for (size_t k = 0; k < g.poses.size(); ++k) {
    if (k > 0) {
      for (const Edge& e : full.edges) {
        if (e.from == static_cast<int>(k) - 1 && e.to == static_cast<int>(k)) {
          expected = expected * e.measurement;
        }
      }
    }
    EXPECT_LT((g.poses[k].translation - expected.translation).norm(), 1e-12) << k;
    EXPECT_LT(g.poses[k].rotation.angularDistance(expected.rotation), 1e-12) << k;
  }
  // A gap in the odometry starts a new chain at the identity (the file
  // gives no vertex for it); composition goes on from there.
  const PoseGraph gap = readString("EDGE_SE2 0 2 1 0 0 1 0 0 1 0 1\nEDGE_SE2 2 1 1 0 0 1 0 0 1 0 1\n"
                                   "EDGE_SE2 3 1 1 0 0 1 0 0 1 0 1\n");
  ASSERT_EQ(gap.poses.size(), 4u);
  EXPECT_EQ(gap.poses[1].translation, Eigen::Vector3d::Zero());
  EXPECT_NEAR(gap.poses[2].translation.x(), -1.0, 1e-12);  // edge 2 -> 1 measures pose 1 in 2's frame
}

}  // namespace
}  // namespace core
}  // namespace agnc_pgo
