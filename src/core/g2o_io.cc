#include "agnc_pgo/core/g2o_io.h"

#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <set>
#include <utility>
#include <vector>

#include <Eigen/Cholesky>
#include "tokenize.h"

namespace agnc_pgo {
namespace core {

ParseError::ParseError(const std::string& file, int line, const std::string& reason)
    : std::runtime_error(file + ":" + std::to_string(line) + ": " + reason),
      file_(file),
      line_(line),
      reason_(reason) {}

namespace {

// Where a token came from, so every error can name file and line.
struct Where {
  const std::string& file;
  int line;
};

[[noreturn]] void fail(const Where& where, const std::string& reason) {
  throw ParseError(where.file, where.line, reason);
}

double parseNumber(const Where& where, const std::string& token) {
  char* end = nullptr;
  const double value = std::strtod(token.c_str(), &end);
  // The whole token must be consumed: "1.5x" or "" is not a number.
  if (end == token.c_str() || *end != '\0') fail(where, "'" + token + "' is not a number");
  if (!std::isfinite(value)) fail(where, "non-finite value '" + token + "'");
  return value;
}

int parseId(const Where& where, const std::string& token) {
  char* end = nullptr;
  errno = 0;
  const long value = std::strtol(token.c_str(), &end, 10);
  if (end == token.c_str() || *end != '\0') fail(where, "'" + token + "' is not an integer id");
  if (value < 0) fail(where, "negative id " + token);
  if (errno == ERANGE || value > INT_MAX) fail(where, "id " + token + " is out of range");
  return static_cast<int>(value);
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
      info(r, c) = info(c, r) = parseNumber(where, tokens[index++]);
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
    if (tokens.empty() || tokens[0][0] == '#') return;
    const Where where{name_, line};
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
      fail(where, "unknown tag '" + tag + "'");
    }
  }

  PoseGraph finish() {
    PoseGraph graph;
    graph.dimension = dimension_ == 0 ? 2 : dimension_;
    if (vertices_.empty()) {
      buildFromEdgesOnly(&graph);
    } else {
      buildFromVertices(&graph);
    }
    for (const FixRecord& fix : fixes_) {
      if (fix.id >= static_cast<int>(graph.poses.size())) {
        fail({name_, fix.line}, "FIX references unknown vertex " + std::to_string(fix.id));
      }
      graph.fixed.push_back(fix.id);
    }
    return graph;
  }

 private:
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
    edge.kind = classifyEdge(from, to);
    edges_.push_back({where.line, edge});
  }

  void parseVertex2(const Where& where, const std::vector<std::string>& t) {
    expectTokenCount(where, t, 5);
    setDimension(where, 2);
    const int id = parseId(where, t[1]);
    const double x = parseNumber(where, t[2]);
    const double y = parseNumber(where, t[3]);
    const double theta = parseNumber(where, t[4]);
    addVertex(where, id, Pose::fromSE2(x, y, theta));
  }

  void parseEdge2(const Where& where, const std::vector<std::string>& t) {
    expectTokenCount(where, t, 12);
    setDimension(where, 2);
    const int from = parseId(where, t[1]);
    const int to = parseId(where, t[2]);
    const Pose z =
        Pose::fromSE2(parseNumber(where, t[3]), parseNumber(where, t[4]), parseNumber(where, t[5]));
    addEdge(where, from, to, z, parseInformation(where, t, 6, 3));
  }

  void parseVertex3(const Where& where, const std::vector<std::string>& t) {
    expectTokenCount(where, t, 9);
    setDimension(where, 3);
    const int id = parseId(where, t[1]);
    Pose pose;
    pose.translation = Eigen::Vector3d(parseNumber(where, t[2]), parseNumber(where, t[3]),
                                       parseNumber(where, t[4]));
    pose.rotation = parseQuaternion(where, t, 5);
    addVertex(where, id, pose);
  }

  void parseEdge3(const Where& where, const std::vector<std::string>& t) {
    expectTokenCount(where, t, 31);
    setDimension(where, 3);
    const int from = parseId(where, t[1]);
    const int to = parseId(where, t[2]);
    Pose z;
    z.translation = Eigen::Vector3d(parseNumber(where, t[3]), parseNumber(where, t[4]),
                                    parseNumber(where, t[5]));
    z.rotation = parseQuaternion(where, t, 6);
    addEdge(where, from, to, z, parseInformation(where, t, 10, 6));
  }

  void parseFix(const Where& where, const std::vector<std::string>& t) {
    if (t.size() < 2) fail(where, "FIX expects at least one id");
    for (size_t i = 1; i < t.size(); ++i) fixes_.push_back({where.line, parseId(where, t[i])});
  }

  // Vertices define the ids; they must be 0..N-1 and every edge must use them.
  void buildFromVertices(PoseGraph* graph) {
    const int n = static_cast<int>(vertices_.size());
    graph->poses.resize(n);
    for (const VertexRecord& v : vertices_) {
      if (v.id >= n) {
        fail({name_, v.line}, "vertex id " + std::to_string(v.id) +
                                  " breaks the contiguous range 0.." + std::to_string(n - 1));
      }
      graph->poses[v.id] = v.pose;
    }
    for (const EdgeRecord& e : edges_) {
      for (int id : {e.edge.from, e.edge.to}) {
        if (!vertex_lines_.count(id)) {
          fail({name_, e.line}, "edge references unknown vertex " + std::to_string(id));
        }
      }
      graph->edges.push_back(e.edge);
    }
  }

  // No vertices: the referenced ids define the poses, composed from odometry.
  void buildFromEdgesOnly(PoseGraph* graph) {
    std::set<int> ids;
    for (const EdgeRecord& e : edges_) ids.insert({e.edge.from, e.edge.to});
    const int n = static_cast<int>(ids.size());
    for (const EdgeRecord& e : edges_) {
      const int id = std::max(e.edge.from, e.edge.to);
      if (id >= n) {
        fail({name_, e.line}, "id " + std::to_string(id) + " breaks the contiguous range 0.." +
                                  std::to_string(n - 1) + " of the ids used by edges");
      }
      graph->edges.push_back(e.edge);
    }
    graph->poses.assign(n, Pose::identity());
    try {
      initializeFromOdometry(graph);
    } catch (const std::runtime_error& error) {
      throw std::runtime_error(name_ + ": " + error.what());
    }
  }

  const std::string& name_;
  int dimension_ = 0;
  int dimension_line_ = 0;
  std::vector<VertexRecord, Eigen::aligned_allocator<VertexRecord>> vertices_;
  std::map<int, int> vertex_lines_;  // id -> line of its VERTEX
  std::vector<EdgeRecord> edges_;
  std::vector<FixRecord> fixes_;
};

// The yaw to print for an SE(2) rotation: yaw() may be an ulp or two away
// from the angle that produced the quaternion, so search the neighbouring
// doubles for one that reproduces it exactly (exact write/read round trip).
double roundTripYaw(const Pose& pose) {
  const double yaw = pose.yaw();
  const auto reproduces = [&pose](double angle) {
    return Pose::fromSE2(0.0, 0.0, angle).rotation.coeffs() == pose.rotation.coeffs();
  };
  double below = yaw;
  double above = yaw;
  for (int step = 0; step < 16; ++step) {
    if (reproduces(below)) return below;
    if (reproduces(above)) return above;
    below = std::nextafter(below, -std::numeric_limits<double>::infinity());
    above = std::nextafter(above, std::numeric_limits<double>::infinity());
  }
  return yaw;  // not an exact planar rotation; the nearest yaw is the best we can do
}

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
  return reader.finish();
}

PoseGraph readG2o(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open g2o file '" + path + "'");
  return readG2o(in, path);
}

void writeG2o(const PoseGraph& graph, std::ostream& out) {
  if (graph.dimension != 2 && graph.dimension != 3) {
    throw std::invalid_argument("writeG2o: dimension must be 2 or 3");
  }
  const bool planar = graph.dimension == 2;
  const std::streamsize old_precision = out.precision(std::numeric_limits<double>::max_digits10);
  const std::ios_base::fmtflags old_flags = out.flags();
  out.unsetf(std::ios_base::floatfield);  // %g-style: shortest exact form

  for (size_t id = 0; id < graph.poses.size(); ++id) {
    const Pose& p = graph.poses[id];
    if (planar) {
      out << "VERTEX_SE2 " << id << ' ' << p.translation.x() << ' ' << p.translation.y() << ' '
          << roundTripYaw(p) << '\n';
    } else {
      out << "VERTEX_SE3:QUAT " << id << ' ';
      writeTranslationQuaternion(p, out);
      out << '\n';
    }
  }
  for (const Edge& e : graph.edges) {
    const Pose& z = e.measurement;
    if (planar) {
      out << "EDGE_SE2 " << e.from << ' ' << e.to << ' ' << z.translation.x() << ' '
          << z.translation.y() << ' ' << roundTripYaw(z);
    } else {
      out << "EDGE_SE3:QUAT " << e.from << ' ' << e.to << ' ';
      writeTranslationQuaternion(z, out);
    }
    writeUpperTriangle(e.information, graph.tangentDimension(), out);
    out << '\n';
  }
  for (int id : graph.fixed) out << "FIX " << id << '\n';

  out.precision(old_precision);
  out.flags(old_flags);
}

void writeG2o(const PoseGraph& graph, const std::string& path) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot open '" + path + "' for writing");
  writeG2o(graph, out);
  out.flush();
  if (!out) throw std::runtime_error("error writing '" + path + "'");
}

}  // namespace core
}  // namespace agnc_pgo
