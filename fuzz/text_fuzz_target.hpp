// The check the text fuzzer runs on every input, shared with the replay test
// (TorqueCsv.FuzzSeedsAndRegressionsReplay in tests/runtime/test_torque_csv.cpp). The first byte
// picks what is fuzzed, the rest is the text:
//   torque CSV (runtime/torque_csv.hpp) for 1..4 joints: rejected with std::invalid_argument
//     naming the file, or a table that keeps every rule (>= 2 samples, finite values, dt > 0);
//   a number list (runtime/text_numbers.hpp): rejected by name, or finite numbers;
//   a comment (generator/emitted_text.hpp): only `//` lines of printable ASCII that cannot
//     continue onto the next line.
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>

#include "comment_rule.hpp"
#include "emitted_text.hpp"
#include "text_numbers.hpp"
#include "torque_csv.hpp"

namespace spacearm::fuzz {

inline void check_torque_csv(const std::string& text, int joints) {
  const std::string source = "fuzz.csv";
  try {
    const TorqueTable t = read_torque_csv(text, joints, source);
    if (t.samples.size() < 2 || !(t.dt > 0) || !std::isfinite(t.t0) || !std::isfinite(t.t_last()))
      throw std::logic_error("torque CSV accepted with a bad grid");
    for (const auto& s : t.samples)
      if (s.size() != joints || !s.allFinite())
        throw std::logic_error("torque CSV accepted with a bad sample");
  } catch (const std::invalid_argument& e) {
    if (std::string(e.what()).rfind("torque file '" + source + "'", 0) != 0)
      throw std::logic_error(std::string("torque CSV rejection does not name the file: ") +
                             e.what());
  }
}

inline void check_number_list(const std::string& text) {
  try {
    for (double v : parse_number_list(text, "--q"))
      if (!std::isfinite(v)) throw std::logic_error("number list accepted a non-finite value");
  } catch (const std::invalid_argument& e) {
    if (std::string(e.what()).rfind("--q", 0) != 0)
      throw std::logic_error(std::string("number rejection does not name the option: ") + e.what());
  }
}

inline void check_comment(const std::string& text) {
  const std::string rule = broken_comment_rule(comment_lines(text));
  if (!rule.empty()) throw std::logic_error(rule);
}

// Throws std::logic_error for a broken rule; lets anything else escape (a crash).
inline void check_text(const std::string& input) {
  if (input.empty()) return;
  const unsigned char mode = static_cast<unsigned char>(input[0]);
  const std::string text = input.substr(1);
  if (mode % 3 == 0)
    check_torque_csv(text, 1 + (mode / 3) % 4);
  else if (mode % 3 == 1)
    check_number_list(text);
  else
    check_comment(text);
}

}  // namespace spacearm::fuzz
