// g2o pose graph files: VERTEX_SE2, EDGE_SE2, VERTEX_SE3:QUAT, EDGE_SE3:QUAT, FIX.
#pragma once

#include <istream>
#include <ostream>
#include <stdexcept>
#include <string>

#include "agnc_pgo/core/pose_graph.h"

namespace agnc_pgo {
namespace core {

// Every parse error names the file, the 1-based line and the reason:
// "FILE:LINE: reason".
class ParseError : public std::runtime_error {
 public:
  ParseError(const std::string& file, int line, const std::string& reason);
  const std::string& file() const { return file_; }
  int line() const { return line_; }
  const std::string& reason() const { return reason_; }

 private:
  std::string file_;
  int line_;
  std::string reason_;
};

// Reads a g2o file. Rejects (ParseError): a wrong token count, a non-number,
// NaN/Inf, an unknown vertex id, a non-positive-definite information matrix, a
// duplicate vertex, mixed 2D/3D tags, unknown tags. A file with edges but no
// vertices is initialised by composing odometry. Ids need not be 0..n-1:
// the poses are the ids in increasing order (PoseGraph::file_ids keeps them),
// and edges are classified on those indices, |i - j| (1 = odometry).
// Quaternions are normalised.
PoseGraph readG2o(const std::string& path);
PoseGraph readG2o(std::istream& in, const std::string& name);

// Writes vertices, edges and FIX lines with full (round-trip) precision,
// under the graph's file ids where it has them.
void writeG2o(const PoseGraph& graph, std::ostream& out);
void writeG2o(const PoseGraph& graph, const std::string& path);

}  // namespace core
}  // namespace agnc_pgo
