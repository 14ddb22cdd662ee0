// Internal to the core's text readers (g2o, .irl): whitespace tokenising.
#pragma once

#include <string>
#include <vector>

namespace agnc_pgo {
namespace core {

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

}  // namespace core
}  // namespace agnc_pgo
