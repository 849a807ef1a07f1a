#include "run_table.hpp"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <set>
#include <stdexcept>

#include "private_folder.hpp"
#include "text_numbers.hpp"
#include "torque_csv.hpp"

namespace spacearm::cli {

int RunTable::column(const std::string& name) const {
  for (size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return static_cast<int>(i);
  return -1;
}

std::vector<double> RunTable::values(int column) const {
  std::vector<double> v;
  v.reserve(rows.size());
  for (const auto& r : rows) v.push_back(r.at(column));
  return v;
}

Fd open_table(const std::string& path, const std::string& what) {
  try {
    return open_regular_file(path, what, ~size_t(0));
  } catch (const FolderError& e) {
    throw std::invalid_argument(e.what());
  }
}

void for_each_line(const std::string& path, const std::string& what,
                   const std::function<void(long, std::string&)>& line) {
  const Fd fd = open_table(path, what);
  const std::string where = what + " '" + path + "'";
  std::string pending, chunk(1 << 20, '\0');
  long number = 0;
  size_t scanned = 0;  // pending holds no newline before this
  const auto emit = [&](std::string text) {
    if (!text.empty() && text.back() == '\r') text.pop_back();
    if (number == 0 && text.compare(0, 3, "\xEF\xBB\xBF") == 0) text.erase(0, 3);
    line(++number, text);
  };
  for (;;) {
    const ssize_t n = ::read(fd.get(), chunk.data(), chunk.size());
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw std::invalid_argument(where + ": read failed: " + std::strerror(errno));
    if (n == 0) break;
    pending.append(chunk.data(), static_cast<size_t>(n));
    size_t start = 0;
    for (size_t end; (end = pending.find('\n', std::max(start, scanned))) != std::string::npos;
         start = end + 1)
      emit(pending.substr(start, end - start));
    pending.erase(0, start);
    scanned = pending.size();
    // A line this long is no table's: refused before it fills memory.
    if (pending.size() > kMaxLineBytes)
      throw std::invalid_argument(where + " line " + std::to_string(number + 1) + ": longer than " +
                                  std::to_string(kMaxLineBytes >> 20) + " MB");
  }
  if (!pending.empty()) emit(pending);
}

namespace {

// Keeps every stride-th row; past 8 max rows, every second one of those (the stride doubles).
// At the end, the stride that leaves at most max rows with the last one (a multiple of the
// stride so far).
struct Thinner {
  long max_rows = 2, stride = 1, index = 0;
  std::vector<std::vector<double>> kept;
  std::vector<double> last;
  void add(std::vector<double>&& row) {
    if (index++ % stride == 0) {
      kept.push_back(row);
      if (static_cast<long>(kept.size()) > 8 * max_rows) {
        std::vector<std::vector<double>> half;
        for (size_t i = 0; i < kept.size(); i += 2) half.push_back(std::move(kept[i]));
        kept = std::move(half);
        stride *= 2;
      }
    }
    last = std::move(row);
  }
  std::vector<std::vector<double>> finish() {
    const long wanted = (index - 1 + max_rows - 2) / (max_rows - 1);  // ceil((n - 1) / (max - 1))
    const long step = std::max(1L, (wanted + stride - 1) / stride);
    std::vector<std::vector<double>> rows;
    for (size_t i = 0; i < kept.size(); i += step) rows.push_back(std::move(kept[i]));
    stride *= step;
    if ((index - 1) % stride != 0) rows.push_back(std::move(last));  // the last row, always
    return rows;
  }
};

}  // namespace

namespace {

constexpr double kMaxDrawnValue = 1e9;

std::string number_text(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", v);
  return text;
}

}  // namespace

RunTable read_run_table(const std::string& path, const std::string& what, long max_rows) {
  RunTable table;
  table.path = path;
  const std::string where = what + " '" + path + "'";
  Thinner thin;
  thin.max_rows = std::max(2L, max_rows);
  int t_column = -1;
  double t_before = 0;
  const auto wall0 = std::chrono::steady_clock::now();
  auto next_report = std::chrono::seconds(2);
  for_each_line(path, what, [&](long number, std::string& text) {
    if (text.find_first_not_of(" \t") == std::string::npos) return;
    const std::string at = where + " line " + std::to_string(number);
    const size_t count = 1 + static_cast<size_t>(std::count(text.begin(), text.end(), ','));
    if (!table.names.empty() && count != table.names.size())
      throw std::invalid_argument(at + ": " + std::to_string(count) + " fields, the header has " +
                                  std::to_string(table.names.size()));
    const auto fields = detail::split_csv_line(text);
    if (table.names.empty()) {  // the header
      std::set<std::string> seen;
      for (const auto& name : fields)
        if (name.empty() || !seen.insert(name).second)
          throw std::invalid_argument(at + ": the header has an empty or repeated column name " +
                                      quoted_text(name));
      table.names = fields;
      t_column = table.column("t");
      if (t_column < 0) throw std::invalid_argument(at + ": the header has no column 't'");
      return;
    }
    std::vector<double> row(fields.size());
    for (size_t i = 0; i < fields.size(); ++i) {
      row[i] = parse_number(fields[i], at + " column " + quoted_text(table.names[i]));
      // The page draws in double and in WebGL's float: beyond 1e9 the arm's geometry and the
      // plots' scales lose every digit (x0 = 1e300 drew nothing), so such a row is refused.
      if (!(std::abs(row[i]) <= kMaxDrawnValue))
        throw std::invalid_argument(at + " column " + quoted_text(table.names[i]) + ": " +
                                    number_text(row[i]) +
                                    " is beyond +-1e9, which the page cannot draw");
    }
    if (table.total_rows > 0 && !(row[t_column] > t_before))
      throw std::invalid_argument(at + ": t = " + fields[t_column] +
                                  " does not increase (the row before has " +
                                  number_text(t_before) + ")");
    // Plots need times that a float axis tells apart: steps of at least 1e-9 of the time.
    if (table.total_rows > 0 &&
        !(row[t_column] - t_before >= 1e-9 * std::max(1.0, std::abs(row[t_column]))))
      throw std::invalid_argument(at + ": t = " + fields[t_column] + " is " +
                                  number_text(row[t_column] - t_before) +
                                  " s after the row before: times closer than 1e-9 s (relative to "
                                  "t, at least 1) cannot be plotted");
    t_before = row[t_column];
    ++table.total_rows;
    thin.add(std::move(row));
    if (std::chrono::steady_clock::now() - wall0 > next_report) {
      std::fprintf(stderr, "spacearm: read %ld rows of %s\n", table.total_rows, path.c_str());
      next_report += std::chrono::seconds(2);
    }
  });
  if (table.names.empty()) throw std::invalid_argument(where + ": empty (no header)");
  if (table.total_rows < 1) throw std::invalid_argument(where + ": no rows after the header");
  table.rows = thin.finish();
  table.stride = thin.stride;
  return table;
}

}  // namespace spacearm::cli
