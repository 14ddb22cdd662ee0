#include "agnc_pgo/ros/graph_sidecar.h"

#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>

#include <Eigen/Cholesky>

#include "agnc_pgo/core/atomic_file.h"
#include "agnc_pgo/core/g2o_io.h"
#include "../core/tokenize.h"

namespace agnc_pgo {
namespace ros_backend {
namespace {

using core::kMaxAbsCoordinate;
using core::kMaxAbsInformation;
using core::ParseError;

constexpr const char* kMagic = "agnc_pgo_sidecar";
constexpr int kVersion = 4;
constexpr int kOldestVersion = 2;  // without the engine's three flags
constexpr int kMaxStep = 1000;              // GNC steps of one graduation (a loop closure needs <= 6)
constexpr int kMaxStepsAtOne = 1000000;
constexpr std::size_t kNodeTokens = 11;     // NODE i sec nsec x y z qx qy qz qw
// LOOP k from to mode, 7 graduation values, uncorroborated undone landed
// (version 3), map_judgements (version 4), 4 stamps, score, label, source
constexpr std::size_t kLoopTokens = 23;
constexpr std::size_t kFlagTokens = 3;       // not in version 2
constexpr std::size_t kJudgementTokens = 1;  // not before version 4
constexpr int kMaxJudgements = 1000000000;

std::string hex(unsigned long value) {
  std::ostringstream out;
  out << std::hex << std::setw(8) << std::setfill('0') << value;
  return out.str();
}

// Sources may hold any bytes; in the file they are one token: '=' followed by
// the bytes, with '%', whitespace, control and non-ASCII bytes as %XX.
std::string encodeSource(const std::string& source) {
  static const char* digits = "0123456789ABCDEF";
  std::string out = "=";
  for (unsigned char c : source) {
    if (c > 0x20 && c < 0x7f && c != '%') {
      out += static_cast<char>(c);
    } else {
      out += '%';
      out += digits[c >> 4];
      out += digits[c & 15];
    }
  }
  return out;
}

int hexDigit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

void checkPoseValue(const core::Pose& p, const std::string& what) {
  if (!p.translation.allFinite() || p.translation.cwiseAbs().maxCoeff() > kMaxAbsCoordinate ||
      !p.rotation.coeffs().allFinite() || std::abs(p.rotation.norm() - 1.0) > 1e-6)
    throw std::invalid_argument(what + " is not a finite pose with a unit quaternion");
}

void writePose(std::ostream& out, const core::Pose& p) {
  out << ' ' << p.translation.x() << ' ' << p.translation.y() << ' ' << p.translation.z() << ' ' << p.rotation.x()
      << ' ' << p.rotation.y() << ' ' << p.rotation.z() << ' ' << p.rotation.w();
}

// The tokens of one line, read left to right; every failure names file and line.
class LineReader {
 public:
  LineReader(const std::string& name, int line, const std::string& text)
      : name_(name), line_(line), tokens_(core::tokenize(text)) {}

  [[noreturn]] void fail(const std::string& reason) const { throw ParseError(name_, line_, reason); }

  std::size_t size() const { return tokens_.size(); }
  void expectCount(std::size_t count) const {
    if (tokens_.size() != count)
      fail("expected " + std::to_string(count) + " tokens, got " + std::to_string(tokens_.size()));
  }
  void keyword(const std::string& key) {
    if (next_ >= tokens_.size() || tokens_[next_] != key)
      fail("expected '" + key + "', found " + (next_ < tokens_.size() ? core::quoteToken(tokens_[next_]) : "end of line"));
    ++next_;
  }
  const std::string& token(const std::string& what) {
    if (next_ >= tokens_.size()) fail("missing " + what);
    return tokens_[next_++];
  }
  double number(const std::string& what) {
    double value = 0.0;
    const std::string reason = core::parseFiniteDouble(token(what), &value);
    if (!reason.empty()) fail(what + ": " + reason);
    return value;
  }
  double numberIn(const std::string& what, double low, double high) {
    const double value = number(what);
    if (!(value >= low && value <= high))
      fail(what + " " + std::to_string(value) + " is outside [" + std::to_string(low) + ", " + std::to_string(high) + "]");
    return value;
  }
  long long integerIn(const std::string& what, long long low, long long high) {
    const std::string& text = token(what);
    if (text.empty() || text.size() > 20 || text.find('\0') != std::string::npos) fail(what + ": bad integer " + core::quoteToken(text));
    char* end = nullptr;
    errno = 0;
    const long long value = std::strtoll(text.c_str(), &end, 10);
    if (end != text.c_str() + text.size() || errno == ERANGE) fail(what + ": bad integer " + core::quoteToken(text));
    if (value < low || value > high)
      fail(what + " " + text + " is outside [" + std::to_string(low) + ", " + std::to_string(high) + "]");
    return value;
  }
  unsigned long crc(const std::string& what) {
    const std::string& text = token(what);
    if (text.size() != 8) fail(what + ": expected 8 hex digits, got " + core::quoteToken(text));
    unsigned long value = 0;
    for (char c : text) {
      const int digit = hexDigit(c);
      if (digit < 0) fail(what + ": expected 8 hex digits, got " + core::quoteToken(text));
      value = value * 16 + static_cast<unsigned long>(digit);
    }
    return value;
  }
  core::Pose pose(const std::string& what) {
    core::Pose p;
    for (int i = 0; i < 3; ++i) p.translation[i] = numberIn(what + " position", -kMaxAbsCoordinate, kMaxAbsCoordinate);
    const double x = number(what + " qx"), y = number(what + " qy"), z = number(what + " qz");
    const double w = number(what + " qw");
    p.rotation = Eigen::Quaterniond(w, x, y, z);
    const double norm = p.rotation.norm();
    if (!(std::abs(norm - 1.0) <= 1e-6)) fail(what + " quaternion is not unit length");
    return p;
  }
  SidecarStamp stamp(const std::string& what) {
    SidecarStamp s;
    s.sec = static_cast<uint32_t>(integerIn(what + " sec", 0, std::numeric_limits<uint32_t>::max()));
    s.nsec = static_cast<uint32_t>(integerIn(what + " nsec", 0, 999999999));
    return s;
  }
  std::string source() {
    const std::string& text = token("source");
    if (text.empty() || text[0] != '=') fail("source must start with '='");
    std::string out;
    for (std::size_t i = 1; i < text.size(); ++i) {
      if (out.size() >= kMaxSourceBytes) fail("source is longer than " + std::to_string(kMaxSourceBytes) + " bytes");
      if (text[i] != '%') {
        out += text[i];
        continue;
      }
      const int high = i + 2 < text.size() ? hexDigit(text[i + 1]) : -1;
      const int low = high >= 0 ? hexDigit(text[i + 2]) : -1;
      if (low < 0) fail("bad %-escape in source");
      out += static_cast<char>(high * 16 + low);
      i += 2;
    }
    return out;
  }

 private:
  const std::string& name_;
  int line_;
  std::vector<std::string> tokens_;
  std::size_t next_ = 0;
};

// Splits into lines, verifies the closing checksum line and returns the
// lines before it.
std::vector<std::string> checkedLines(const std::string& text, const std::string& name) {
  if (text.compare(0, 19, "agnc_pgo_sidecar 1\n") == 0)
    throw ParseError(name, 1, "version-1 sidecar: it has no checksum, so it cannot be matched to its g2o file safely");
  std::vector<std::string> lines;
  std::size_t begin = 0;
  while (begin < text.size()) {
    std::size_t end = text.find('\n', begin);
    if (end == std::string::npos) end = text.size();
    lines.push_back(text.substr(begin, end - begin));
    begin = end + 1;
  }
  const int last = static_cast<int>(lines.size());
  if (last < 2 || text.back() != '\n' || lines.back().compare(0, 9, "checksum ") != 0)
    throw ParseError(name, std::max(last, 1), "file is truncated (no checksum line)");
  LineReader checksum(name, last, lines.back());
  checksum.expectCount(2);
  checksum.keyword("checksum");
  const unsigned long expected = checksum.crc("checksum");
  const std::size_t body = text.size() - lines.back().size() - 1;
  if (core::crc32Of(text.substr(0, body)) != expected)
    throw ParseError(name, last, "checksum mismatch: the file is corrupt or was modified");
  lines.pop_back();
  return lines;
}

class SidecarParser {
 public:
  SidecarParser(const std::string& text, const std::string& name) : name_(name), lines_(checkedLines(text, name)) {}

  Sidecar parse() {
    Sidecar s;
    {
      LineReader r = line();
      r.expectCount(2);
      r.keyword(kMagic);
      version_ = static_cast<int>(r.integerIn("version", 0, 1000000));
      if (version_ < kOldestVersion || version_ > kVersion)
        r.fail("unsupported sidecar version (this back-end reads versions 2 to 4)");
    }
    {
      LineReader r = line();
      r.expectCount(3);
      r.keyword("g2o");
      s.g2o_bytes = static_cast<std::size_t>(r.integerIn("g2o size", 0, std::numeric_limits<long long>::max()));
      s.g2o_crc = r.crc("g2o checksum");
    }
    {
      LineReader r = line();
      r.expectCount(2);
      r.keyword("dimension");
      s.dimension = static_cast<int>(r.integerIn("dimension", 2, 3));
    }
    parsePrior(&s);
    const std::size_t nodes = count("nodes");
    for (std::size_t i = 0; i < nodes; ++i) parseNode(&s, i);
    s.odometry_edges = count("odometry_edges");
    const std::size_t loops = count("loops");
    for (std::size_t k = 0; k < loops; ++k) parseLoop(&s, k);
    if (next_ < lines_.size()) line().fail("unexpected line after the last LOOP");
    return s;
  }

 private:
  LineReader line() {
    if (next_ >= lines_.size()) throw ParseError(name_, static_cast<int>(next_ + 1), "file ends early");
    const std::size_t index = next_++;
    return LineReader(name_, static_cast<int>(index + 1), lines_[index]);
  }

  // A count can never exceed the lines left, so no count allocates beyond the file.
  std::size_t count(const std::string& key) {
    LineReader r = line();
    r.expectCount(2);
    r.keyword(key);
    return static_cast<std::size_t>(r.integerIn(key, 0, static_cast<long long>(lines_.size())));
  }

  void parsePrior(Sidecar* s) {
    LineReader r = line();
    const int t = s->dimension == 2 ? 3 : 6;
    r.expectCount(9 + static_cast<std::size_t>(t * t));
    r.keyword("prior");
    s->prior_value = r.pose("prior");
    r.integerIn("prior size", t, t);
    s->prior_information.resize(t, t);
    for (int i = 0; i < t * t; ++i)
      s->prior_information(i / t, i % t) = r.numberIn("prior information", -kMaxAbsInformation, kMaxAbsInformation);
    const Eigen::MatrixXd& info = s->prior_information;
    if ((info - info.transpose()).cwiseAbs().maxCoeff() > 1e-9 * info.cwiseAbs().maxCoeff())
      r.fail("prior information is not symmetric");
    if (Eigen::LLT<Eigen::MatrixXd>(info).info() != Eigen::Success) r.fail("prior information is not positive definite");
  }

  void parseNode(Sidecar* s, std::size_t i) {
    LineReader r = line();
    r.expectCount(kNodeTokens);
    r.keyword("NODE");
    r.integerIn("NODE index", static_cast<long long>(i), static_cast<long long>(i));
    const SidecarStamp stamp = r.stamp("stamp");
    if (!s->stamps.empty() && stamp <= s->stamps.back()) r.fail("keyframe stamps do not increase");
    s->stamps.push_back(stamp);
    s->odom_poses.push_back(r.pose("odometry pose"));
  }

  void parseLoop(Sidecar* s, std::size_t k) {
    LineReader r = line();
    r.expectCount(kLoopTokens - (version_ < 4 ? kJudgementTokens : 0) - (version_ < 3 ? kFlagTokens : 0));
    r.keyword("LOOP");
    r.integerIn("LOOP index", static_cast<long long>(k), static_cast<long long>(k));
    const long long last_node = static_cast<long long>(s->stamps.size()) - 1;
    SidecarLoop l;
    l.from = static_cast<int>(r.integerIn("from", 0, last_node));
    l.to = static_cast<int>(r.integerIn("to", 0, last_node));
    if (l.from == l.to) r.fail("loop closure joins a node to itself");
    l.state.override_mode = static_cast<core::LoopOverride>(r.integerIn("override mode", 0, 2));
    core::GraduationState& g = l.state.graduation;
    g.mu = r.numberIn("mu", 0.0, 1.0);
    g.step = static_cast<int>(r.integerIn("step", 0, kMaxStep));
    g.init_step = static_cast<int>(r.integerIn("init_step", 0, kMaxStep));
    g.mu_init = r.numberIn("mu_init", 0.0, 1.0);
    g.alpha = r.numberIn("alpha", 0.0, 1.0);
    g.steps_at_one = static_cast<int>(r.integerIn("steps_at_one", 0, kMaxStepsAtOne));
    g.graduating = r.integerIn("graduating", 0, 1) != 0;
    if (version_ >= 3) {
      l.state.uncorroborated = r.integerIn("uncorroborated", 0, 1) != 0;
      l.state.undone = r.integerIn("undone", 0, 1) != 0;
      l.state.landed = r.integerIn("landed", 0, 1) != 0;
    }
    if (version_ >= 4) l.state.map_judgements = static_cast<int>(r.integerIn("map_judgements", 0, kMaxJudgements));
    l.from_stamp = r.stamp("from stamp");
    l.to_stamp = r.stamp("to stamp");
    l.score = r.numberIn("score", -1e300, 1e300);
    l.is_outlier = r.integerIn("outlier label", 0, 1) != 0;
    l.source = r.source();
    s->loops.push_back(l);
  }

  const std::string& name_;
  std::vector<std::string> lines_;
  std::size_t next_ = 0;
  int version_ = kVersion;
};

}  // namespace

std::string formatSidecar(const Sidecar& s, const std::string& g2o_text) {
  const std::size_t n = s.stamps.size();
  if (s.odom_poses.size() != n) throw std::invalid_argument("sidecar: stamps and odometry poses differ in number");
  if (!s.prior_information.allFinite()) throw std::invalid_argument("sidecar: prior information is not finite");
  checkPoseValue(s.prior_value, "the prior");
  std::ostringstream out;
  out << std::setprecision(std::numeric_limits<double>::max_digits10);
  out << kMagic << ' ' << kVersion << '\n'
      << "g2o " << g2o_text.size() << ' ' << hex(core::crc32Of(g2o_text)) << '\n'
      << "dimension " << s.dimension << '\n'
      << "prior";
  writePose(out, s.prior_value);
  const int t = static_cast<int>(s.prior_information.rows());
  out << ' ' << t;
  for (int r = 0; r < t; ++r)
    for (int c = 0; c < t; ++c) out << ' ' << s.prior_information(r, c);
  out << '\n' << "nodes " << n << '\n';
  for (std::size_t i = 0; i < n; ++i) {
    checkPoseValue(s.odom_poses[i], "odometry pose " + std::to_string(i));
    out << "NODE " << i << ' ' << s.stamps[i].sec << ' ' << s.stamps[i].nsec;
    writePose(out, s.odom_poses[i]);
    out << '\n';
  }
  out << "odometry_edges " << s.odometry_edges << '\n' << "loops " << s.loops.size() << '\n';
  for (std::size_t k = 0; k < s.loops.size(); ++k) {
    const SidecarLoop& l = s.loops[k];
    const core::GraduationState& g = l.state.graduation;
    if (!std::isfinite(l.score) || !std::isfinite(g.mu) || !std::isfinite(g.mu_init) || !std::isfinite(g.alpha))
      throw std::invalid_argument("sidecar: loop closure " + std::to_string(k) + " has a non-finite value");
    if (l.source.size() > kMaxSourceBytes)
      throw std::invalid_argument("sidecar: source of loop closure " + std::to_string(k) + " is too long");
    out << "LOOP " << k << ' ' << l.from << ' ' << l.to << ' ' << static_cast<int>(l.state.override_mode) << ' ' << g.mu
        << ' ' << g.step << ' ' << g.init_step << ' ' << g.mu_init << ' ' << g.alpha << ' ' << g.steps_at_one << ' '
        << (g.graduating ? 1 : 0) << ' ' << (l.state.uncorroborated ? 1 : 0) << ' ' << (l.state.undone ? 1 : 0) << ' '
        << (l.state.landed ? 1 : 0) << ' ' << l.state.map_judgements << ' ' << l.from_stamp.sec << ' ' << l.from_stamp.nsec << ' ' << l.to_stamp.sec
        << ' ' << l.to_stamp.nsec << ' ' << l.score << ' ' << (l.is_outlier ? 1 : 0) << ' '
        << encodeSource(l.source) << '\n';
  }
  const std::string body = out.str();
  return body + "checksum " + hex(core::crc32Of(body)) + "\n";
}

Sidecar parseSidecar(const std::string& text, const std::string& name) { return SidecarParser(text, name).parse(); }

std::string sidecarMismatch(const Sidecar& s, const std::string& g2o_text, const core::PoseGraph& graph) {
  if (s.g2o_bytes != g2o_text.size() || s.g2o_crc != core::crc32Of(g2o_text))
    return "it was saved with a different g2o file (size/CRC-32 differ)";
  if (s.dimension != graph.dimension) return "its dimension differs from the g2o file";
  if (s.stamps.size() != graph.poses.size()) return "its node count differs from the g2o file";
  if (s.odometry_edges > graph.edges.size() || s.odometry_edges + s.loops.size() != graph.edges.size())
    return "its edge counts differ from the g2o file";
  for (std::size_t k = 0; k < s.loops.size(); ++k) {
    const core::Edge& e = graph.edges[s.odometry_edges + k];
    if (e.from != s.loops[k].from || e.to != s.loops[k].to)
      return "LOOP " + std::to_string(k) + " does not match its g2o edge";
  }
  return "";
}

}  // namespace ros_backend
}  // namespace agnc_pgo
