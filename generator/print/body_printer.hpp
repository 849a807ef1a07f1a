// Prints a straight-line program (straight_line.hpp) as the statements of a C++ body: the
// nodes that several entries share, and every sin/cos, as named temporaries (sin/cos batched per
// level), then each entry as an assignment; long bodies in parts that pass values through a work
// array. Knows programs and the spellings of array entries, nothing of models.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "straight_line.hpp"

namespace spacearm {

// How a body names array entries: the Eigen header's q(i) and M(i, j), or the C interface's
// plain column-major arrays q[i] and M[i + rows * j] (no Eigen to compile: fast first use).
enum class Spelling { eigen, c_arrays };

// One assignment of a function's body: a result entry (target = its value) or, with no root, a
// copy of another entry (target = source).
struct Assignment {
  std::string target;
  SRef root;
  std::string source;
};

class BodyPrinterImpl;

// Prints the nodes of a program that several entries share (and every sin/cos) as named
// temporaries t0, t1, ..., then each entry as an assignment, in parts of per_part temporaries
// (PrintOptions::statements_per_part; 0: one part; a sin/cos batch stays whole, in the part of
// its first sin/cos), each entry in the part of its last operand and the copies of symmetric
// entries in the last. Plain: everything inline.
class BodyPrinter {
 public:
  BodyPrinter(const Program& p, const std::vector<Assignment>& assignments, bool plain,
              Spelling spelling = Spelling::eigen, int per_part = 0);
  ~BodyPrinter();
  int num_parts() const;
  int work_size() const;
  bool has_trig_batches() const;
  // The statements of part k ("  const T t3 = ...;", "  w[2] = ...;", "  M[0] = ...;").
  const std::string& part(int k) const;
  // An entry's value as an expression (a temporary's name, or inline where plain).
  std::string value(const SRef& root) const;

 private:
  std::unique_ptr<BodyPrinterImpl> impl_;
};

}  // namespace spacearm
