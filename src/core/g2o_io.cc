#include "agnc_pgo/core/g2o_io.h"

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <sstream>
#include <utility>
#include <vector>

#include <Eigen/Cholesky>
#include "agnc_pgo/core/atomic_file.h"
#include "tokenize.h"

namespace agnc_pgo {
namespace core {

ParseError::ParseError(const std::string& file, int line, const std::string& reason)
    : std::runtime_error(file + ":" + std::to_string(line) + ": " + reason),
      file_(file),
      line_(line),
      reason_(reason) {}

namespace {

constexpr const char* kFormatTag = "agnc_pgo_g2o";

// Where a token came from, so every error can name file and line.
struct Where {
  const std::string& file;
  int line;
};

[[noreturn]] void fail(const Where& where, const std::string& reason) {
  throw ParseError(where.file, where.line, reason);
}

double parseNumber(const Where& where, const std::string& token) {
  double value = 0.0;
  const std::string reason = parseFiniteDouble(token, &value);
  if (!reason.empty()) fail(where, reason);
  return value;
}

// A pose component: finite and within kMaxAbsCoordinate.
double parseCoordinate(const Where& where, const std::string& token) {
  const double value = parseNumber(where, token);
  if (std::abs(value) > kMaxAbsCoordinate) {
    fail(where, "implausible magnitude " + quoteToken(token) + " (limit " +
                    std::to_string(static_cast<long long>(kMaxAbsCoordinate)) + ")");
  }
  return value;
}

int parseId(const Where& where, const std::string& token) {
  int value = 0;
  const std::string reason = parseNonNegativeInt(token, &value);
  if (reason.empty()) return value;
  if (reason.compare(0, 8, "negative") == 0) fail(where, "negative id " + quoteToken(token));
  if (reason.find("out of range") != std::string::npos) fail(where, "id " + quoteToken(token) + " is out of range");
  fail(where, quoteToken(token) + " is not an integer id");
}

void expectTokenCount(const Where& where, const std::vector<std::string>& tokens, size_t count) {
  if (tokens.size() != count) {
    fail(where, tokens[0] + " expects " + std::to_string(count - 1) + " values, got " +
                    std::to_string(tokens.size() - 1));
  }
}

// Reads qx qy qz qw starting at tokens[first]. Already-unit quaternions are
// kept bit for bit (renormalising can change the last digit, which would
// break exact write/read round trips); others are normalised.
Eigen::Quaterniond parseQuaternion(const Where& where, const std::vector<std::string>& tokens,
                                   size_t first) {
  const double x = parseNumber(where, tokens[first]);
  const double y = parseNumber(where, tokens[first + 1]);
  const double z = parseNumber(where, tokens[first + 2]);
  const double w = parseNumber(where, tokens[first + 3]);
  Eigen::Quaterniond q(w, x, y, z);
  const double squared_norm = q.squaredNorm();
  if (!(squared_norm > 1e-24)) fail(where, "quaternion has zero norm");
  // Components of 1e154 and more overflow the norm to inf (and normalise to
  // NaN); anything far from unit length is not a rotation someone wrote.
  if (!(squared_norm < 1e6)) fail(where, "quaternion norm is implausibly large");
  if (std::abs(squared_norm - 1.0) > 1e-15) q.normalize();
  return q;
}

// Reads the upper triangle (row-major) of an n x n information matrix
// starting at tokens[first], mirrors it and requires positive definiteness.
Eigen::MatrixXd parseInformation(const Where& where, const std::vector<std::string>& tokens,
                                 size_t first, int n) {
  Eigen::MatrixXd info(n, n);
  size_t index = first;
  for (int r = 0; r < n; ++r) {
    for (int c = r; c < n; ++c) {
      const std::string& token = tokens[index++];
      info(r, c) = info(c, r) = parseNumber(where, token);
      if (std::abs(info(r, c)) > kMaxAbsInformation) {
        fail(where, "implausible information entry " + quoteToken(token) + " (limit 1e15)");
      }
    }
  }
  if (Eigen::LLT<Eigen::MatrixXd>(info).info() != Eigen::Success) {
    fail(where, "information matrix is not positive definite");
  }
  return info;
}

struct VertexRecord {
  int id;
  int line;
  Pose pose;
};

struct EdgeRecord {
  int line;
  Edge edge;
};

struct FixRecord {
  int line;
  int id;
};

// Accumulates the records of one file; checks that need the whole file
// (ids, contiguity) run in finish().
class G2oReader {
 public:
  explicit G2oReader(const std::string& name) : name_(name) {}

  void parseLine(const std::string& text, int line) {
    const std::vector<std::string> tokens = tokenize(text);
    if (tokens.empty()) return;
    const Where where{name_, line};
    if (trailer_line_ > 0) fail(where, "data after the end line (line " + std::to_string(trailer_line_) + ")");
    if (tokens[0][0] == '#') return parseComment(where, tokens);
    const std::string& tag = tokens[0];
    if (tag == "VERTEX_SE2") {
      parseVertex2(where, tokens);
    } else if (tag == "EDGE_SE2") {
      parseEdge2(where, tokens);
    } else if (tag == "VERTEX_SE3:QUAT") {
      parseVertex3(where, tokens);
    } else if (tag == "EDGE_SE3:QUAT") {
      parseEdge3(where, tokens);
    } else if (tag == "FIX") {
      parseFix(where, tokens);
    } else {
      fail(where, "unknown tag " + quoteToken(tag));
    }
  }

  PoseGraph finish(int last_line) {
    checkAnnouncedCounts(last_line);
    if (vertices_.empty() && edges_.empty()) fail({name_, last_line}, "no vertices and no edges");
    PoseGraph graph;
    graph.dimension = dimension_ == 0 ? 2 : dimension_;
    numberPoses(&graph);
    if (vertices_.empty()) {
      buildFromEdgesOnly(&graph);
    } else {
      buildFromVertices(&graph);
    }
    for (const FixRecord& fix : fixes_) {
      const auto found = index_.find(fix.id);
      if (found == index_.end()) fail({name_, fix.line}, "FIX references unknown vertex " + std::to_string(fix.id));
      graph.fixed.push_back(found->second);
    }
    return graph;
  }

 private:
  // "# agnc_pgo_g2o vertices V edges E fix F" heads a file writeG2o wrote and
  // "# agnc_pgo_g2o end" ends it; other comments are ignored.
  void parseComment(const Where& where, const std::vector<std::string>& t) {
    if (t[0] != "#" || t.size() < 2 || t[1] != kFormatTag) return;
    if (t.size() == 3 && t[2] == "end") {
      if (header_line_ == 0) fail(where, "end line without a header line");
      trailer_line_ = where.line;
      return;
    }
    if (t.size() != 8 || t[2] != "vertices" || t[4] != "edges" || t[6] != "fix")
      fail(where, std::string("malformed header (expected '# ") + kFormatTag + " vertices V edges E fix F')");
    if (header_line_ > 0) fail(where, "second header line (first on line " + std::to_string(header_line_) + ")");
    if (!vertices_.empty() || !edges_.empty() || !fixes_.empty()) fail(where, "header line after data");
    header_line_ = where.line;
    announced_vertices_ = parseId(where, t[3]);
    announced_edges_ = parseId(where, t[5]);
    announced_fixes_ = parseId(where, t[7]);
  }

  // A file with a header must hold exactly what it announces and end with the
  // end line: a save cut anywhere (even inside a number) is refused.
  void checkAnnouncedCounts(int last_line) const {
    if (header_line_ == 0) return;
    const Where where{name_, last_line};
    if (trailer_line_ == 0)
      fail(where, std::string("file is truncated: no '# ") + kFormatTag + " end' line (header on line " +
                      std::to_string(header_line_) + ")");
    const auto check = [&](const char* what, int announced, size_t found) {
      if (static_cast<size_t>(announced) != found)
        fail(where, std::string("file is truncated or altered: header announces ") + std::to_string(announced) +
                        " " + what + ", found " + std::to_string(found));
    };
    check("vertices", announced_vertices_, vertices_.size());
    check("edges", announced_edges_, edges_.size());
    check("FIX ids", announced_fixes_, fixes_.size());
  }

  void setDimension(const Where& where, int dimension) {
    if (dimension_ == 0) {
      dimension_ = dimension;
      dimension_line_ = where.line;
    } else if (dimension_ != dimension) {
      fail(where, "mixed 2D and 3D tags (the file is " + std::to_string(dimension_) +
                      "D since line " + std::to_string(dimension_line_) + ")");
    }
  }

  void addVertex(const Where& where, int id, const Pose& pose) {
    const auto inserted = vertex_lines_.emplace(id, where.line);
    if (!inserted.second) {
      fail(where, "duplicate vertex " + std::to_string(id) + " (first defined on line " +
                      std::to_string(inserted.first->second) + ")");
    }
    vertices_.push_back({id, where.line, pose});
  }

  void addEdge(const Where& where, int from, int to, const Pose& measurement,
               Eigen::MatrixXd information) {
    if (from == to) fail(where, "edge connects vertex " + std::to_string(from) + " to itself");
    Edge edge;
    edge.from = from;
    edge.to = to;
    edge.measurement = measurement;
    edge.information = std::move(information);
    edges_.push_back({where.line, edge});
  }

  void parseVertex2(const Where& where, const std::vector<std::string>& t) {
    expectTokenCount(where, t, 5);
    setDimension(where, 2);
    const int id = parseId(where, t[1]);
    const double x = parseCoordinate(where, t[2]);
    const double y = parseCoordinate(where, t[3]);
    const double theta = parseCoordinate(where, t[4]);
    addVertex(where, id, Pose::fromSE2(x, y, theta));
  }

  void parseEdge2(const Where& where, const std::vector<std::string>& t) {
    expectTokenCount(where, t, 12);
    setDimension(where, 2);
    const int from = parseId(where, t[1]);
    const int to = parseId(where, t[2]);
    const Pose z =
        Pose::fromSE2(parseCoordinate(where, t[3]), parseCoordinate(where, t[4]), parseCoordinate(where, t[5]));
    addEdge(where, from, to, z, parseInformation(where, t, 6, 3));
  }

  void parseVertex3(const Where& where, const std::vector<std::string>& t) {
    expectTokenCount(where, t, 9);
    setDimension(where, 3);
    const int id = parseId(where, t[1]);
    Pose pose;
    pose.translation = Eigen::Vector3d(parseCoordinate(where, t[2]), parseCoordinate(where, t[3]),
                                       parseCoordinate(where, t[4]));
    pose.rotation = parseQuaternion(where, t, 5);
    addVertex(where, id, pose);
  }

  void parseEdge3(const Where& where, const std::vector<std::string>& t) {
    expectTokenCount(where, t, 31);
    setDimension(where, 3);
    const int from = parseId(where, t[1]);
    const int to = parseId(where, t[2]);
    Pose z;
    z.translation = Eigen::Vector3d(parseCoordinate(where, t[3]), parseCoordinate(where, t[4]),
                                    parseCoordinate(where, t[5]));
    z.rotation = parseQuaternion(where, t, 6);
    addEdge(where, from, to, z, parseInformation(where, t, 10, 6));
  }

  void parseFix(const Where& where, const std::vector<std::string>& t) {
    if (t.size() < 2) fail(where, "FIX expects at least one id");
    for (size_t i = 1; i < t.size(); ++i) fixes_.push_back({where.line, parseId(where, t[i])});
  }

  // The poses are the file's ids in increasing order: the vertices', or
  // without vertices those the edges use. g2o numbers poses in the order
  // they were taken, and a skipped id (a keyframe a front-end dropped) is
  // not a pose, so pose i is the i-th id and the edge between two
  // neighbours in that order is odometry. Ids other than 0..n-1 are kept
  // in graph->file_ids for writeG2o.
  void numberPoses(PoseGraph* graph) {
    std::vector<int> ids;
    for (const VertexRecord& v : vertices_) ids.push_back(v.id);
    if (vertices_.empty())
      for (const EdgeRecord& e : edges_) ids.insert(ids.end(), {e.edge.from, e.edge.to});
    std::sort(ids.begin(), ids.end());
    ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
    for (size_t i = 0; i < ids.size(); ++i) index_.emplace(ids[i], static_cast<int>(i));
    if (!ids.empty() && ids.back() != static_cast<int>(ids.size()) - 1) graph->file_ids = ids;
  }

  // Every edge must use the vertices' ids; it is renumbered as the poses are.
  void buildFromVertices(PoseGraph* graph) {
    graph->poses.resize(vertices_.size());
    for (const VertexRecord& v : vertices_) graph->poses[index_.at(v.id)] = v.pose;
    for (const EdgeRecord& e : edges_) {
      for (int id : {e.edge.from, e.edge.to}) {
        if (!vertex_lines_.count(id)) {
          fail({name_, e.line}, "edge references unknown vertex " + std::to_string(id));
        }
      }
      graph->edges.push_back(renumbered(e.edge));
    }
  }

  // No vertices: the referenced ids define the poses, composed from odometry.
  void buildFromEdgesOnly(PoseGraph* graph) {
    for (const EdgeRecord& e : edges_) graph->edges.push_back(renumbered(e.edge));
    graph->poses.assign(index_.size(), Pose::identity());
    try {
      initializeFromOdometry(graph);
    } catch (const std::runtime_error& error) {
      throw std::runtime_error(name_ + ": " + error.what());
    }
    checkComposedPoses(*graph);
  }

  Edge renumbered(Edge edge) const {
    edge.from = index_.at(edge.from);
    edge.to = index_.at(edge.to);
    edge.kind = classifyEdge(edge.from, edge.to);
    return edge;
  }

  // Odometry that composes beyond kMaxAbsCoordinate (or to inf) is refused at
  // the line of the first edge that leads there.
  void checkComposedPoses(const PoseGraph& graph) const {
    for (size_t k = 0; k < graph.poses.size(); ++k) {
      const Eigen::Vector3d& t = graph.poses[k].translation;
      if (t.allFinite() && t.cwiseAbs().maxCoeff() <= kMaxAbsCoordinate) continue;
      int line = edges_.empty() ? 0 : edges_.back().line;
      for (const EdgeRecord& e : edges_) {
        const Edge edge = renumbered(e.edge);
        if (std::max(edge.from, edge.to) == static_cast<int>(k) && edge.kind == EdgeKind::kOdometry) {
          line = e.line;
          break;
        }
      }
      fail({name_, line}, "composing the odometry puts pose " + std::to_string(graph.fileId(static_cast<int>(k))) +
                              " at an implausible position (beyond 1e9 m)");
    }
  }

  const std::string& name_;
  int dimension_ = 0;
  int dimension_line_ = 0;
  std::vector<VertexRecord, Eigen::aligned_allocator<VertexRecord>> vertices_;
  std::map<int, int> vertex_lines_;  // id -> line of its VERTEX
  std::map<int, int> index_;         // id -> pose index (numberPoses)
  std::vector<EdgeRecord> edges_;
  std::vector<FixRecord> fixes_;
  int header_line_ = 0, trailer_line_ = 0;
  int announced_vertices_ = 0, announced_edges_ = 0, announced_fixes_ = 0;
};

// The yaw to print for an SE(2) rotation, so that save -> load -> save is
// byte-identical (also through the engine, which keeps an SE(2) rotation as
// its yaw). A rotation fromSE2 made is printed as its yaw(), which fromSE2
// turns back into exactly it. Any other (a product of rotations) is first
// replaced by the one fromSE2 makes of its yaw, a change of an ulp at most.
double roundTripYaw(const Pose& pose) { return Pose::fromSE2(0.0, 0.0, pose.yaw()).yaw(); }

void writeUpperTriangle(const Eigen::MatrixXd& info, int n, std::ostream& out) {
  if (info.rows() != n || info.cols() != n) {
    throw std::invalid_argument("writeG2o: information matrix must be " + std::to_string(n) + "x" +
                                std::to_string(n));
  }
  for (int r = 0; r < n; ++r) {
    for (int c = r; c < n; ++c) out << ' ' << info(r, c);
  }
}

void writeTranslationQuaternion(const Pose& pose, std::ostream& out) {
  const Eigen::Vector3d& t = pose.translation;
  const Eigen::Quaterniond& q = pose.rotation;
  out << t.x() << ' ' << t.y() << ' ' << t.z() << ' ' << q.x() << ' ' << q.y() << ' ' << q.z()
      << ' ' << q.w();
}

}  // namespace

PoseGraph readG2o(std::istream& in, const std::string& name) {
  G2oReader reader(name);
  std::string text;
  int line = 0;
  while (std::getline(in, text)) reader.parseLine(text, ++line);
  if (in.bad()) throw std::runtime_error(name + ": read error");
  return reader.finish(std::max(line, 1));
}

PoseGraph readG2o(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open g2o file '" + path + "'");
  return readG2o(in, path);
}

// No inf or NaN may reach a file: it could not be read back.
void checkFinite(const PoseGraph& graph) {
  for (size_t id = 0; id < graph.poses.size(); ++id) {
    const Pose& p = graph.poses[id];
    if (!p.translation.allFinite() || !p.rotation.coeffs().allFinite())
      throw std::invalid_argument("writeG2o: pose " + std::to_string(id) + " is not finite");
  }
  for (size_t k = 0; k < graph.edges.size(); ++k) {
    const Edge& e = graph.edges[k];
    if (!e.measurement.translation.allFinite() || !e.measurement.rotation.coeffs().allFinite() ||
        !e.information.allFinite())
      throw std::invalid_argument("writeG2o: edge " + std::to_string(k) + " is not finite");
  }
}

// The file ids must read back as the same poses: one per pose, increasing.
void checkFileIds(const PoseGraph& graph) {
  if (graph.file_ids.empty()) return;
  if (graph.file_ids.size() != graph.poses.size())
    throw std::invalid_argument("writeG2o: " + std::to_string(graph.file_ids.size()) + " file ids for " +
                                std::to_string(graph.poses.size()) + " poses");
  for (size_t k = 0; k < graph.file_ids.size(); ++k)
    if (graph.file_ids[k] < 0 || (k > 0 && graph.file_ids[k] <= graph.file_ids[k - 1]))
      throw std::invalid_argument("writeG2o: file ids must be non-negative and increasing (pose " +
                                  std::to_string(k) + ")");
}

void writeG2o(const PoseGraph& graph, std::ostream& out) {
  if (graph.dimension != 2 && graph.dimension != 3) {
    throw std::invalid_argument("writeG2o: dimension must be 2 or 3");
  }
  checkFinite(graph);
  checkFileIds(graph);
  const bool planar = graph.dimension == 2;
  const std::streamsize old_precision = out.precision(std::numeric_limits<double>::max_digits10);
  const std::ios_base::fmtflags old_flags = out.flags();
  out.unsetf(std::ios_base::floatfield);  // %g-style: shortest exact form

  out << "# " << kFormatTag << " vertices " << graph.poses.size() << " edges " << graph.edges.size() << " fix "
      << graph.fixed.size() << '\n';
  for (int index = 0; index < static_cast<int>(graph.poses.size()); ++index) {
    const Pose& p = graph.poses[index];
    const int id = graph.fileId(index);
    if (planar) {
      out << "VERTEX_SE2 " << id << ' ' << p.translation.x() << ' ' << p.translation.y() << ' ' << roundTripYaw(p)
          << '\n';
    } else {
      out << "VERTEX_SE3:QUAT " << id << ' ';
      writeTranslationQuaternion(p, out);
      out << '\n';
    }
  }
  for (const Edge& e : graph.edges) {
    const Pose& z = e.measurement;
    if (planar) {
      out << "EDGE_SE2 " << graph.fileId(e.from) << ' ' << graph.fileId(e.to) << ' ' << z.translation.x() << ' '
          << z.translation.y() << ' ' << roundTripYaw(z);
    } else {
      out << "EDGE_SE3:QUAT " << graph.fileId(e.from) << ' ' << graph.fileId(e.to) << ' ';
      writeTranslationQuaternion(z, out);
    }
    writeUpperTriangle(e.information, graph.tangentDimension(), out);
    out << '\n';
  }
  for (int id : graph.fixed) out << "FIX " << graph.fileId(id) << '\n';
  out << "# " << kFormatTag << " end\n";

  out.precision(old_precision);
  out.flags(old_flags);
}

void writeG2o(const PoseGraph& graph, const std::string& path) {
  std::ostringstream out;
  writeG2o(graph, out);
  writeFileAtomically(path, out.str());
}

}  // namespace core
}  // namespace agnc_pgo
