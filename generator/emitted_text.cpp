#include "emitted_text.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <stdexcept>

namespace spacearm {

namespace {

// Generated at build time from the compiler's `-dM -E` output (see the header).
const char* const kMacros[] = {
#include "reserved_macros.inc"
};

}  // namespace

std::string comment_lines(const std::string& text, const std::string& indent) {
  std::string out = indent + "//";
  bool line_has_text = false;
  auto end_line = [&] {
    out += "\n" + indent + "//";
    line_has_text = false;
  };
  for (size_t i = 0; i < text.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c == '\r' || c == '\n') {
      if (c == '\r' && i + 1 < text.size() && text[i + 1] == '\n') ++i;
      end_line();
      continue;
    }
    if (!line_has_text) out += ' ';
    line_has_text = true;
    // A '?' after a '?' is escaped too: "??/" is a trigraph (a backslash) in older modes.
    const bool trigraph = c == '?' && i > 0 && text[i - 1] == '?';
    if (c >= 0x20 && c < 0x7f && c != '\\' && !trigraph) {
      out += static_cast<char>(c);
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02X", c);
      out += buf;
    }
  }
  return out + "\n";
}

void check_file_stem(const std::string& stem, const std::string& what) {
  auto allowed = [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-' || c == '.';
  };
  const bool ok = !stem.empty() && stem.size() <= 100 && stem[0] != '-' && stem[0] != '.' &&
                  std::all_of(stem.begin(), stem.end(), allowed);
  if (!ok) {
    std::string shown;
    for (char c : stem.substr(0, 100)) shown += (c >= 0x20 && c < 0x7f) ? c : '?';
    throw std::invalid_argument(
        what + ": '" + shown +
        "' is not a safe file name stem (1-100 letters, digits, '_', '-' or '.', "
        "not starting with '-' or '.')");
  }
}

std::string round_trip(double value) {
  if (!std::isfinite(value)) throw std::invalid_argument("round_trip: value is not finite");
  char buf[64];
  for (int digits = 15; digits <= 17; ++digits) {
    std::snprintf(buf, sizeof buf, "%.*g", digits, value);
    if (std::strtod(buf, nullptr) == value) break;
  }
  std::string s = buf;
  // A plain integer would be an int literal in C++: keep it a floating-point literal.
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

bool is_cpp_reserved(const std::string& name) {
  // C++20 keywords and alternative tokens.
  // clang-format off
  static const std::set<std::string> keywords = {
      "alignas", "alignof", "and", "and_eq", "asm", "auto", "bitand", "bitor", "bool", "break",
      "case", "catch", "char", "char16_t", "char32_t", "char8_t", "class", "compl", "concept",
      "const", "consteval", "constexpr", "constinit", "const_cast", "continue", "co_await",
      "co_return", "co_yield", "decltype", "default", "delete", "do", "double", "dynamic_cast",
      "else", "enum", "explicit", "export", "extern", "false", "float", "for", "friend", "goto",
      "if", "import", "inline", "int", "long", "module", "mutable", "namespace", "new",
      "noexcept", "not", "not_eq", "nullptr", "operator", "or", "or_eq", "private", "protected",
      "public", "register", "reinterpret_cast", "requires", "return", "short", "signed", "sizeof",
      "static", "static_assert", "static_cast", "struct", "switch", "template", "this",
      "thread_local", "throw", "true", "try", "typedef", "typeid", "typename", "union",
      "unsigned", "using", "virtual", "void", "volatile", "wchar_t", "while", "xor", "xor_eq"};
  // clang-format on
  static const std::set<std::string> macros(std::begin(kMacros), std::end(kMacros));
  return keywords.count(name) || macros.count(name) || name.find("__") != std::string::npos ||
         (!name.empty() && name[0] == '_');
}

}  // namespace spacearm
