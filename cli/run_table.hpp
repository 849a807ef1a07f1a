// A run's CSV (spacearm simulate or plan, a sweep's series/run-*.csv, a table written from
// Python) read for drawing: columns by header name, every row checked (a finite number in each
// field, t increasing), and only up to `max_rows` rows kept, evenly spaced with the last one
// included, so that a file of 10^7 rows is read in bounded memory.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "private_folder.hpp"

namespace spacearm::cli {

struct RunTable {
  std::string path;
  std::vector<std::string> names;
  std::vector<std::vector<double>> rows;  // the rows kept, in order
  long total_rows = 0;                    // rows in the file
  long stride = 1;                        // rows kept: every stride-th, and the last
  // The column's index, or -1.
  int column(const std::string& name) const;
  std::vector<double> values(int column) const;
  bool thinned() const { return static_cast<long>(rows.size()) < total_rows; }
};

// The longest line a table may have (about 40 000 numbers): a longer one is an error, so that a
// file without newlines cannot fill memory.
constexpr size_t kMaxLineBytes = size_t(1) << 20;

// A table file opened for reading, checked to be a regular file (private_folder.hpp: a FIFO or a
// device cannot block); errors are std::invalid_argument naming `what` and the path.
Fd open_table(const std::string& path, const std::string& what);

// Calls line(number, text) for each line of the table at `path` (open_table), read in 1 MB
// chunks, without the \r of CRLF and a leading byte-order mark; errors name `what` and the path.
void for_each_line(const std::string& path, const std::string& what,
                   const std::function<void(long, std::string&)>& line);

// Errors name `what` (an argument or option), the file, the line and the column.
RunTable read_run_table(const std::string& path, const std::string& what, long max_rows);

}  // namespace spacearm::cli
