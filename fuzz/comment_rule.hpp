// The rule every comment written by comment_lines() keeps, shared by the scene and text
// fuzzers: only `//` lines of printable ASCII, none ending in a backslash (which would
// splice the next line into it), and a line break at the end.
#pragma once

#include <string>

namespace spacearm::fuzz {

// Empty when `comment` keeps the rule, else what breaks it.
inline std::string broken_comment_rule(const std::string& comment) {
  size_t start = 0;
  for (size_t end; (end = comment.find('\n', start)) != std::string::npos; start = end + 1) {
    const std::string line = comment.substr(start, end - start);
    if (line.compare(0, 2, "//") != 0 || line.back() == '\\')
      return "comment line escapes: " + line;
    for (unsigned char c : line)
      if (c < 0x20 || c >= 0x7f) return "unescaped byte in a comment line";
  }
  if (start != comment.size()) return "comment does not end with a line break";
  return "";
}

}  // namespace spacearm::fuzz
