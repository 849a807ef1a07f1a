// The check the view fuzzer runs on every input, shared with the replay test
// (RunTableTest.FuzzSeedsAndRegressionsReplay in tests/cli/test_run_table.cpp): spacearm view's
// untrusted inputs. The first byte picks what is fuzzed, the rest is the file's text:
//   even: a run's CSV (cli/run_table.hpp), read with at most 2..41 rows kept: an error naming
//     the file, or a table that keeps every rule (a 't' column, t increasing by at least 1e-9
//     of itself, every value finite and within 1e9, rows of the header's length, at most the
//     rows asked for and the last row kept);
//   odd: a run's provenance record (cli/provenance.hpp) beside a CSV: nothing, a record, or an
//     error naming the record that never quotes the input's text.
// Files are written into a private scratch folder of the process (the readers take paths).
#pragma once

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <stdexcept>
#include <string>

#include "provenance.hpp"
#include "run_table.hpp"

namespace spacearm::fuzz {

inline std::string scratch_file(const std::string& name, const std::string& text) {
  static const std::filesystem::path dir = [] {
    const auto d = std::filesystem::temp_directory_path() /
                   ("spacearm-view-fuzz-" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    return d;
  }();
  const std::string path = (dir / name).string();
  std::ofstream(path, std::ios::binary | std::ios::trunc) << text;
  return path;
}

inline void check_run_table(const std::string& text, long max_rows) {
  const std::string path = scratch_file("run.csv", text);
  try {
    const cli::RunTable t = cli::read_run_table(path, "view", max_rows);
    const int tc = t.column("t");
    if (tc < 0 || t.rows.empty() || static_cast<long>(t.rows.size()) > std::max(2L, max_rows))
      throw std::logic_error("run table accepted without t or with too many rows");
    for (size_t k = 0; k < t.rows.size(); ++k) {
      if (t.rows[k].size() != t.names.size()) throw std::logic_error("a row of another length");
      for (double v : t.rows[k])
        if (!(std::abs(v) <= 1e9)) throw std::logic_error("a value the page cannot draw");
      if (k > 0 && !(t.rows[k][tc] > t.rows[k - 1][tc])) throw std::logic_error("t not increasing");
    }
  } catch (const std::invalid_argument& e) {
    if (std::string(e.what()).rfind("view '" + path + "'", 0) != 0)
      throw std::logic_error(std::string("run table rejection does not name the file: ") +
                             e.what());
  }
}

inline void check_provenance(const std::string& text) {
  const std::string csv = scratch_file("record.csv", "t,x\n0,1\n1,2\n");
  const std::string record = scratch_file("record.csv.provenance.json", text);
  try {
    bool stale = false;
    cli::read_provenance(csv, &stale);
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what(), named = "the run's provenance '" + record + "'";
    if (what.rfind(named, 0) != 0)
      throw std::logic_error("provenance rejection does not name the record: " + what);
    // The record may be any file: after its name the message is one of spacearm's own
    // sentences, with a byte offset or one of the record's field names (no input text).
    static const std::regex own(
        ": not spacearm's provenance \\((not JSON at byte [0-9]+|a number out of range"
        "|not a JSON object|a parameter's value is not a number"
        "|field '(command|folder|scene|spacearm|parameters|csv_size|csv_mtime_ns)' "
        "(missing|is not (a string|an object|an integer)))\\); remove it or fix it"
        "| is a symbolic link, not the record spacearm wrote; remove it");
    if (!std::regex_match(what.substr(named.size()), own))
      throw std::logic_error("provenance rejection says more than spacearm's sentence: " + what);
  }
}

// Throws std::logic_error for a broken rule; lets anything else escape (a crash).
inline void check_view_input(const std::string& input) {
  if (input.empty()) return;
  const unsigned char mode = static_cast<unsigned char>(input[0]);
  const std::string text = input.substr(1);
  if (mode % 2 == 0)
    check_run_table(text, 2 + (mode / 2) % 40);
  else
    check_provenance(text);
}

}  // namespace spacearm::fuzz
