// Joint torques from a CSV file, read so that a file means what it says: columns are found
// by their header names (`t`, then `tau1` .. `tauN`, in any order); unknown, missing or
// repeated names, a file without a header, a non-uniform or too fine time grid and any
// field that is not a finite number are errors naming the file, line and column.
// CRLF line ends and a UTF-8 byte-order mark are accepted.
// tau_i is the torque on joint i's link side (the gear's output); a geared joint's motor
// coordinate receives tau_i / p_i (paper eq. 14).
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <cstdlib>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "text_numbers.hpp"

namespace spacearm {

struct TorqueTable {
  double t0 = 0, dt = 0;                 // uniform grid: t_k = t0 + k dt
  std::vector<Eigen::VectorXd> samples;  // tau at t_k, one value per joint
  double t_last() const { return t0 + dt * static_cast<double>(samples.size() - 1); }
};

namespace detail {
inline std::vector<std::string> split_csv_line(const std::string& line) {
  std::vector<std::string> fields;
  size_t start = 0;
  for (;;) {
    const size_t comma = line.find(',', start);
    std::string f =
        line.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    const size_t a = f.find_first_not_of(" \t"), b = f.find_last_not_of(" \t");
    fields.push_back(a == std::string::npos ? "" : f.substr(a, b - a + 1));
    if (comma == std::string::npos) return fields;
    start = comma + 1;
  }
}
}  // namespace detail

// The column names a file for `num_joints` joints must have.
inline std::vector<std::string> torque_csv_columns(int num_joints) {
  std::vector<std::string> names{"t"};
  for (int j = 1; j <= num_joints; ++j) names.push_back("tau" + std::to_string(j));
  return names;
}

// Empty if samples from t = first to last cover a run from 0 to t_end (to rounding); else
// "t = first .. last s, the run needs 0 .. t_end s", for the caller's error message.
inline std::string coverage_gap(double first, double last, double t_end) {
  const double tol = 1e-9 * std::max(1.0, t_end);
  if (first <= tol && last >= t_end - tol) return "";
  return "t = " + number_text(first) + " .. " + number_text(last) + " s, the run needs 0 .. " +
         number_text(t_end) + " s";
}

namespace detail {

// Errors name the file and the line (0: the file as a whole).
struct CsvErrors {
  std::string where;
  std::invalid_argument operator()(long line, const std::string& what) const {
    return std::invalid_argument(where + (line > 0 ? " line " + std::to_string(line) : "") + ": " +
                                 what);
  }
};

// The non-blank lines with their numbers, without a byte-order mark and without the \r of CRLF.
inline std::vector<std::pair<long, std::string>> csv_lines(const std::string& text) {
  std::vector<std::pair<long, std::string>> lines;
  size_t start = text.compare(0, 3, "\xEF\xBB\xBF") == 0 ? 3 : 0;
  for (long number = 1; start < text.size(); ++number) {
    size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    std::string line = text.substr(start, end - start);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") != std::string::npos) lines.push_back({number, line});
    start = end + 1;
  }
  return lines;
}

// The header's column index of each expected name: every one exactly once, nothing else.
inline std::map<std::string, size_t> csv_columns(const std::vector<std::string>& header, long line,
                                                 const std::vector<std::string>& expected,
                                                 const CsvErrors& fail) {
  std::string list;
  for (const auto& n : expected) list += (list.empty() ? "" : ",") + n;
  // Text of the file is shown only where it looks like a name or a number: a study may name any
  // file (/etc/shadow, /proc/self/environ), whose contents must not reach a message.
  auto shown = [](const std::string& text) {
    char* end = nullptr;
    std::strtod(text.c_str(), &end);
    const bool number = !text.empty() && *end == '\0' && text.size() <= 24;
    const bool name = !text.empty() && text.size() <= 16 &&
                      text.find_first_not_of(
                          "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                          "0123456789_") == std::string::npos;
    return number || name;
  };
  if (!header[0].empty() && (std::isdigit(static_cast<unsigned char>(header[0][0])) ||
                             header[0][0] == '-' || header[0][0] == '+' || header[0][0] == '.'))
    throw fail(line, "starts with data" +
                         (shown(header[0]) ? " (" + quoted_text(header[0]) + ")" : std::string()) +
                         ", not a header; add the header line " + list);
  std::map<std::string, size_t> column;
  for (size_t c = 0; c < header.size(); ++c) {
    if (std::find(expected.begin(), expected.end(), header[c]) == expected.end())
      throw fail(line, "unknown column " +
                           (shown(header[c]) ? quoted_text(header[c])
                                             : std::to_string(c + 1) + " (not a column name)") +
                           " (expected " + list + ")");
    if (!column.insert({header[c], c}).second)
      throw fail(line, "column " + quoted_text(header[c]) + " appears twice");
  }
  for (const auto& n : expected)
    if (!column.count(n)) throw fail(line, "missing column '" + n + "' (expected " + list + ")");
  return column;
}

// Sets table.t0 and table.dt from the sample times, which must lie on a uniform grid that t
// can resolve; line_of(k) is the file line of sample k.
template <class LineOf>
void set_uniform_grid(TorqueTable& table, const std::vector<double>& times, LineOf&& line_of,
                      const CsvErrors& fail) {
  // A step that t can still resolve (16 ulps of the largest time).
  table.t0 = times.front();
  table.dt = (times.back() - times.front()) / static_cast<double>(times.size() - 1);
  const double scale = std::max(std::abs(times.front()), std::abs(times.back()));
  if (!(table.dt > 16 * std::numeric_limits<double>::epsilon() * std::max(scale, 1e-300)))
    throw fail(0, "time step " + number_text(table.dt) +
                      " is not positive or too small to resolve at t = " + number_text(scale));
  // Each step equal to the first, within what a decimal file with 7 digits can hold.
  const double first = times[1] - times[0];
  for (size_t k = 1; k < times.size(); ++k) {
    const double step = times[k] - times[k - 1];
    if (!(std::abs(step - first) <= 1e-6 * std::abs(first)))
      throw fail(line_of(k), "time step " + number_text(step) + " differs from the first step " +
                                 number_text(first) + " (the grid must be uniform)");
  }
  // Small steps that each pass can still add up: every time must sit on t0 + k dt.
  for (size_t k = 1; k < times.size(); ++k) {
    const double off = times[k] - (table.t0 + table.dt * static_cast<double>(k));
    if (!(std::abs(off) <= 1e-6 * table.dt))
      throw fail(line_of(k), "time " + quoted_text(number_text(times[k])) + " is " +
                                 number_text(off / table.dt, 3) +
                                 " steps off the uniform grid t0 + k dt (the steps drift)");
  }
}

}  // namespace detail

inline TorqueTable read_torque_csv(const std::string& text, int num_joints,
                                   const std::string& source) {
  const std::string where = "torque file '" + source + "'";
  const detail::CsvErrors fail{where};
  const std::vector<std::string> expected = torque_csv_columns(num_joints);
  const auto lines = detail::csv_lines(text);
  if (lines.empty()) {
    std::string list;
    for (const auto& n : expected) list += (list.empty() ? "" : ",") + n;
    throw fail(0, "empty; expected a header " + list + " and at least two rows");
  }
  const auto header = detail::split_csv_line(lines[0].second);
  const auto column = detail::csv_columns(header, lines[0].first, expected, fail);

  // Rows.
  TorqueTable table;
  std::vector<double> times;
  for (size_t r = 1; r < lines.size(); ++r) {
    const long number = lines[r].first;  // not a structured binding: lambdas capture it
    const auto fields = detail::split_csv_line(lines[r].second);
    if (fields.size() != header.size())
      throw fail(number, "expected " + std::to_string(header.size()) + " fields, got " +
                             std::to_string(fields.size()));
    auto value = [&](const std::string& name) {
      return parse_number(fields[column.at(name)],
                          where + " line " + std::to_string(number) + ", column '" + name + "'");
    };
    times.push_back(value("t"));
    Eigen::VectorXd tau(num_joints);
    for (int j = 0; j < num_joints; ++j) tau[j] = value(expected[j + 1]);
    table.samples.push_back(tau);
  }
  if (times.size() < 2)
    throw fail(0, "needs at least two rows of samples, got " + std::to_string(times.size()));
  detail::set_uniform_grid(
      table, times, [&](size_t k) { return lines[k + 1].first; }, fail);
  return table;
}

}  // namespace spacearm
