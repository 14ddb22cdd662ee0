#include "agnc_pgo/eval/irl_io.h"

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include <Eigen/Cholesky>
#include "../core/tokenize.h"

namespace agnc_pgo {
namespace core {

namespace {

constexpr int kHeaderLines = 5;

std::string trim(const std::string& text) {
  const char* whitespace = " \t\r\n\v\f";
  const std::string::size_type begin = text.find_first_not_of(whitespace);
  if (begin == std::string::npos) return "";
  return text.substr(begin, text.find_last_not_of(whitespace) - begin + 1);
}

// Walks the tokens of one entry; every failure names file, line and what was
// expected, so a short or malformed line is reported precisely.
class EntryTokens {
 public:
  EntryTokens(const std::string& file, int line, std::vector<std::string> tokens)
      : file_(file), line_(line), tokens_(std::move(tokens)) {}

  [[noreturn]] void fail(const std::string& reason) const {
    throw ParseError(file_, line_, reason);
  }

  const std::string& tag() const { return tokens_[0]; }
  bool atEnd() const { return next_ >= tokens_.size(); }
  const std::string& peek(const std::string& what) const {
    if (atEnd()) {
      fail(tag() + " has too few values (" + std::to_string(tokens_.size()) +
           " tokens, missing " + what + ")");
    }
    return tokens_[next_];
  }
  const std::string& next(const std::string& what) {
    const std::string& token = peek(what);
    ++next_;
    return token;
  }

  double number(const std::string& what) {
    const std::string& token = next(what);
    double value = 0.0;
    const std::string reason = parseFiniteDouble(token, &value);
    if (!reason.empty()) fail(reason + " (" + what + ")");
    return value;
  }

  // A pose component: finite and within kMaxAbsCoordinate.
  double coordinate(const std::string& what) {
    const double value = number(what);
    if (std::abs(value) > kMaxAbsCoordinate) {
      fail("implausible magnitude " + quoteToken(tokens_[next_ - 1]) + " (" + what + ", limit 1e9)");
    }
    return value;
  }

  int integer(const std::string& what) {
    const std::string& token = next(what);
    int value = 0;
    const std::string reason = parseNonNegativeInt(token, &value);
    if (!reason.empty()) fail(what + ": " + reason);
    return value;
  }

  void expectEnd() const {
    if (!atEnd()) {
      fail(tag() + " has too many values (" + std::to_string(tokens_.size()) +
           " tokens, unexpected " + quoteToken(tokens_[next_]) + ")");
    }
  }

 private:
  const std::string& file_;
  int line_;
  std::vector<std::string> tokens_;
  size_t next_ = 1;  // tokens_[0] is the tag
};

Pose readPose(int dimension, EntryTokens* t) {
  if (dimension == 2) {
    const double x = t->coordinate("x"), y = t->coordinate("y"), theta = t->coordinate("theta");
    return Pose::fromSE2(x, y, theta);
  }
  const double x = t->coordinate("x"), y = t->coordinate("y"), z = t->coordinate("z");
  const double rx = t->coordinate("rx"), ry = t->coordinate("ry"), rz = t->coordinate("rz");
  return Pose::fromXYZRPY(x, y, z, rx, ry, rz);
}

// Reads a row-major covariance and returns the information matrix in g2o
// order. SE(3) covariances are in GTSAM's tangent order (rx ry rz x y z), so
// they are permuted to x y z rx ry rz before inverting.
Eigen::MatrixXd readInformation(int dimension, EntryTokens* t) {
  const int n = dimension == 2 ? 3 : 6;
  Eigen::MatrixXd file_cov(n, n);
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) file_cov(r, c) = t->number("covariance entry");
  }
  Eigen::MatrixXd cov = file_cov;
  if (dimension == 3) {
    const int g2o_to_file[6] = {3, 4, 5, 0, 1, 2};
    for (int r = 0; r < n; ++r) {
      for (int c = 0; c < n; ++c) cov(r, c) = file_cov(g2o_to_file[r], g2o_to_file[c]);
    }
  }
  // The generator prints covariances with last-digit asymmetry; average it out.
  cov = 0.5 * (cov + cov.transpose()).eval();
  const Eigen::LLT<Eigen::MatrixXd> llt(cov);
  if (llt.info() != Eigen::Success) t->fail("covariance is not positive definite");
  const Eigen::MatrixXd inverse = llt.solve(Eigen::MatrixXd::Identity(n, n));
  const Eigen::MatrixXd info = 0.5 * (inverse + inverse.transpose());
  // A covariance of 1e-320 inverts to inf; one near that to absurd weights.
  if (!info.allFinite() || info.cwiseAbs().maxCoeff() > kMaxAbsInformation)
    t->fail("covariance is too small: its information exceeds 1e15 or is not finite");
  if (Eigen::LLT<Eigen::MatrixXd>(info).info() != Eigen::Success)
    t->fail("covariance is numerically singular (its inverse is not positive definite)");
  return info;
}

// Tracks which poses exist so far: entries may refer to existing poses and
// odometry may add the next one (riSAM logs are strictly incremental).
class IrlReader {
 public:
  IrlReader(const std::string& name, int dimension) : name_(name), dimension_(dimension) {}

  void parseEntry(const std::string& text, int line, IncrementalLog* log) {
    std::vector<std::string> tokens = tokenize(text);
    if (tokens.empty() || tokens[0][0] == '#') return;
    EntryTokens t(name_, line, std::move(tokens));
    LogEntry entry;
    if (t.tag() == "PRIOR") {
      entry = parsePrior(&t);
    } else if (t.tag() == "ODOMETRY") {
      entry = parseOdometry(&t);
    } else if (t.tag() == "LOOP") {
      entry = parseLoop(&t);
    } else {
      t.fail("unknown entry type " + quoteToken(t.tag()));
    }
    t.expectEnd();
    log->entries.push_back(entry);
  }

 private:
  // PRIOR and ODOMETRY carry a single, known-correct mode.
  void readSingleCorrectMode(EntryTokens* t) {
    const int modes = t->integer("number of modes");
    if (modes != 1) t->fail(t->tag() + " must have exactly 1 mode, got " + std::to_string(modes));
    if (t->integer("correct flag") != 0) t->fail(t->tag() + " must be marked correct (0)");
  }

  int existingPose(EntryTokens* t, const std::string& what) {
    const int id = t->integer(what);
    if (id >= num_poses_) {
      t->fail(what + " " + std::to_string(id) + " does not exist yet (poses 0.." +
              std::to_string(num_poses_ - 1) + ")");
    }
    return id;
  }

  LogEntry parsePrior(EntryTokens* t) {
    readSingleCorrectMode(t);
    LogEntry entry;
    entry.type = EntryType::kPrior;
    entry.edge.from = entry.edge.to = existingPose(t, "pose");
    entry.edge.measurement = readPose(dimension_, t);
    entry.edge.information = readInformation(dimension_, t);
    entry.edge.kind = EdgeKind::kOdometry;  // a known inlier
    return entry;
  }

  LogEntry parseOdometry(EntryTokens* t) {
    readSingleCorrectMode(t);
    LogEntry entry;
    entry.type = EntryType::kOdometry;
    entry.edge.from = existingPose(t, "pose");
    entry.edge.to = t->integer("pose");
    if (entry.edge.to != entry.edge.from + 1) {
      t->fail("ODOMETRY must join pose i to i+1, got " + std::to_string(entry.edge.from) + " -> " +
              std::to_string(entry.edge.to));
    }
    num_poses_ = std::max(num_poses_, entry.edge.to + 1);
    entry.edge.measurement = readPose(dimension_, t);
    entry.edge.information = readInformation(dimension_, t);
    entry.edge.kind = EdgeKind::kOdometry;
    return entry;
  }

  // LOOP <modes> <correct> <i> then <modes> alternatives, each NULL or
  // "j pose cov"; exactly one must be a measurement (the generator's
  // [measurement, NULL] pair).
  LogEntry parseLoop(EntryTokens* t) {
    const int modes = t->integer("number of modes");
    if (modes < 1) t->fail("LOOP must have at least 1 mode");
    const int correct = t->integer("correct flag");
    LogEntry entry;
    entry.type = EntryType::kLoopClosure;
    entry.edge.kind = EdgeKind::kLoopClosure;
    entry.edge.is_outlier = correct != 0;
    entry.edge.from = existingPose(t, "pose");
    int measurements = 0;
    for (int mode = 0; mode < modes; ++mode) {
      if (t->peek("mode " + std::to_string(mode + 1)) == "NULL") {
        t->next("NULL");
        continue;
      }
      if (++measurements > 1) t->fail("LOOP has more than one non-NULL mode (unsupported)");
      entry.edge.to = existingPose(t, "pose");
      if (entry.edge.to == entry.edge.from) {
        t->fail("LOOP joins pose " + std::to_string(entry.edge.from) + " to itself");
      }
      entry.edge.measurement = readPose(dimension_, t);
      entry.edge.information = readInformation(dimension_, t);
    }
    if (measurements == 0) t->fail("LOOP has no non-NULL mode");
    return entry;
  }

  const std::string& name_;
  int dimension_;
  int num_poses_ = 1;  // pose 0 is the origin of every log
};

// Reads the five header lines (name, date, dimension, "nonlinear", notes).
void readHeader(std::istream& in, const std::string& name, IncrementalLog* log, int* line) {
  std::string header[kHeaderLines];
  for (int i = 0; i < kHeaderLines; ++i) {
    if (!std::getline(in, header[i])) {
      throw ParseError(name, *line + 1, "file ends inside the 5-line header");
    }
    ++*line;
  }
  log->name = trim(header[0]);
  const std::string dimension = trim(header[2]);
  if (dimension != "2" && dimension != "3") {
    throw ParseError(name, 3, "dimension must be 2 or 3, got " + quoteToken(dimension));
  }
  log->dimension = dimension == "2" ? 2 : 3;
  if (trim(header[3]) != "nonlinear") {
    throw ParseError(name, 4, "expected 'nonlinear', got " + quoteToken(trim(header[3])));
  }
}

}  // namespace

IncrementalLog readIrl(std::istream& in, const std::string& name) {
  IncrementalLog log;
  int line = 0;
  readHeader(in, name, &log, &line);
  IrlReader reader(name, log.dimension);
  std::string text;
  while (std::getline(in, text)) reader.parseEntry(text, ++line, &log);
  if (in.bad()) throw std::runtime_error(name + ": read error");
  return log;
}

IncrementalLog readIrl(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open .irl file '" + path + "'");
  return readIrl(in, path);
}

}  // namespace core
}  // namespace agnc_pgo
