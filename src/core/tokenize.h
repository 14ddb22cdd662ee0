// Internal to the core's text readers (g2o, .irl, the back-end's sidecar):
// whitespace tokenising and strict number parsing with bounded error text.
#pragma once

#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

namespace agnc_pgo {
namespace core {

// Magnitudes no real pose graph reaches. Larger values are rejected by the
// readers: squared residuals of such values overflow or cancel catastrophically
// (1e308 in one edge moves the whole map), so they are input errors, not data.
constexpr double kMaxAbsCoordinate = 1e9;    // [m] and [rad], any pose component
constexpr double kMaxAbsInformation = 1e15;  // any information-matrix entry

// Splits a line at any whitespace; no empty tokens.
inline std::vector<std::string> tokenize(const std::string& line) {
  std::vector<std::string> tokens;
  const char* whitespace = " \t\r\n\v\f";
  std::string::size_type begin = line.find_first_not_of(whitespace);
  while (begin != std::string::npos) {
    const std::string::size_type end = line.find_first_of(whitespace, begin);
    tokens.push_back(line.substr(begin, end - begin));
    begin = line.find_first_not_of(whitespace, end);
  }
  return tokens;
}

// A token as an error message may quote it: at most 40 characters (a 100 MB
// token must not make a 100 MB message), NUL and control bytes escaped.
inline std::string quoteToken(const std::string& token) {
  constexpr std::string::size_type kMaxQuoted = 40;
  std::string quoted = "'";
  for (std::string::size_type i = 0; i < token.size() && i < kMaxQuoted; ++i) {
    const unsigned char c = static_cast<unsigned char>(token[i]);
    if (c < 0x20 || c == 0x7f) {
      static const char* hex = "0123456789abcdef";
      quoted += "\\x";
      quoted += hex[c >> 4];
      quoted += hex[c & 15];
    } else {
      quoted += static_cast<char>(c);
    }
  }
  quoted += "'";
  if (token.size() > kMaxQuoted) quoted += " (" + std::to_string(token.size()) + " bytes, truncated)";
  return quoted;
}

// Parses a whole token as a finite double. Returns "" or the reason it is not
// one. The token must be consumed to its last byte, so an embedded NUL byte
// ("1\0junk") is not a number.
inline std::string parseFiniteDouble(const std::string& token, double* value) {
  if (token.empty() || token.find('\0') != std::string::npos) return quoteToken(token) + " is not a number";
  char* end = nullptr;
  *value = std::strtod(token.c_str(), &end);
  if (end != token.c_str() + token.size()) return quoteToken(token) + " is not a number";
  if (!std::isfinite(*value)) return "non-finite value " + quoteToken(token);
  return "";
}

// Parses a whole token as an integer in [0, INT_MAX]. Returns "" or the reason.
inline std::string parseNonNegativeInt(const std::string& token, int* value) {
  if (token.empty() || token.find('\0') != std::string::npos) return quoteToken(token) + " is not an integer";
  char* end = nullptr;
  errno = 0;
  const long parsed = std::strtol(token.c_str(), &end, 10);
  if (end != token.c_str() + token.size()) return quoteToken(token) + " is not an integer";
  if (parsed < 0) return "negative value " + quoteToken(token);
  if (errno == ERANGE || parsed > INT_MAX) return quoteToken(token) + " is out of range";
  *value = static_cast<int>(parsed);
  return "";
}

}  // namespace core
}  // namespace agnc_pgo
