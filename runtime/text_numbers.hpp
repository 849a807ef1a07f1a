// Strict reading of numbers from text (command-line options, CSV fields): the whole text
// must be one finite decimal number in the range of double. Errors name what was read
// (an option, a file's line and column) and quote the text.
#pragma once

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace spacearm {

// A number in a message: `digits` significant digits, never printf's %f (which shows 1e-7 as
// 0.000000 and 1e300 with 300 digits).
inline std::string number_text(double v, int digits = 10) {
  std::ostringstream s;
  s.precision(digits);
  s << v;
  return s.str();
}

// Shown in messages: at most 40 characters, control characters as '?'.
inline std::string quoted_text(const std::string& text) {
  std::string s;
  for (char c : text.substr(0, 40))
    s += (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) ? '?' : c;
  return "'" + s + (text.size() > 40 ? "...'" : "'");
}

// One number; `what` names the field in the error message.
inline double parse_number(const std::string& text, const std::string& what) {
  if (text.empty()) throw std::invalid_argument(what + ": empty, expected a number");
  if (text.find('\0') != std::string::npos)
    throw std::invalid_argument(what + ": " + quoted_text(text) +
                                " holds a NUL byte, not a number");
  if (text.size() > 100)
    throw std::invalid_argument(what + ": " + quoted_text(text) + " is too long for a number");
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  const bool whole = end != text.c_str() && *end == '\0';
  if (whole && !std::isfinite(v))
    throw std::invalid_argument(what + ": " + quoted_text(text) + " is not finite");
  // Decimal only: no leading blanks and no hexadecimal (which strtod would also take).
  const char c0 = text[0];
  const bool decimal =
      (std::isdigit(static_cast<unsigned char>(c0)) || c0 == '+' || c0 == '-' || c0 == '.') &&
      text.find_first_of("xXpP") == std::string::npos;
  if (!whole || !decimal)
    throw std::invalid_argument(what + ": " + quoted_text(text) + " is not a number" +
                                (whole || *end != ',' ? "" : " (a decimal comma? write a point)"));
  if (errno == ERANGE)
    throw std::invalid_argument(what + ": " + quoted_text(text) +
                                " is out of the range of double precision");
  return v;
}

// "a,b,c": exactly `count` numbers (count < 0: any number of them, at least one). Empty
// items (",1", "1,,2", "1,") are errors.
inline std::vector<double> parse_number_list(const std::string& text, const std::string& what,
                                             int count = -1) {
  std::vector<double> values;
  size_t start = 0;
  for (;;) {
    const size_t comma = text.find(',', start);
    const std::string item =
        text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    const std::string where = what + "[" + std::to_string(values.size()) + "]";
    if (item.empty())
      throw std::invalid_argument(where + ": empty item in " + quoted_text(text) +
                                  " (a stray or trailing comma?)");
    values.push_back(parse_number(item, where));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (count >= 0 && static_cast<int>(values.size()) != count)
    throw std::invalid_argument(what + ": expected " + std::to_string(count) +
                                " comma-separated values, got " + std::to_string(values.size()));
  return values;
}

}  // namespace spacearm
