// Straight-line code as a DAG of arithmetic nodes, with common-subexpression elimination.
//
// Hand-written because GiNaC has no CSE: it hash-conses nothing across expressions and
// re-expands products, so printing its expressions directly repeats every shared term.
// Here identical nodes are created once (hash-consing), and a greedy pass factors out the
// pairs of operands that several sums or products share (as SymPy's cse does).
#pragma once

#include <functional>
#include <map>
#include <string>
#include <tuple>
#include <vector>

namespace spacearm {

// A reference to a node, possibly negated.
struct SRef {
  int id = -1;
  bool neg = false;
  SRef operator-() const { return {id, !neg}; }
  bool operator<(const SRef& o) const { return std::tie(id, neg) < std::tie(o.id, o.neg); }
  bool operator==(const SRef& o) const { return id == o.id && neg == o.neg; }
};

struct OpCounts {
  int adds = 0;  // additions, subtractions and negations
  int muls = 0;
  int divs = 0;
  int trig = 0;       // sin and cos calls (a sin/cos pair of one angle counts 2)
  int functions = 0;  // tanh and exp calls (smooth friction)
  int total_arithmetic() const { return adds + muls + divs; }
};

class Program {
 public:
  enum class Kind { input, constant, add, mul, div, sin, cos, pow, tanh, exp };
  struct Node {
    Kind kind;
    std::vector<SRef> args;  // add: signed terms; mul: factors (never negated); div: {num, den}
    std::string text;        // input: the array's name; constant: literal
    double value = 0;        // constant value (> 0); pow: the exponent
    int index = 0;           // input: the entry of the array
  };

  // share = false: every node is new (no hash-consing), for the unoptimized baseline.
  explicit Program(bool share = true) : share_(share) {}

  SRef input(const std::string& array, int index);  // entry `index` of an input array
  SRef constant(double value);  // any sign; zero is not allowed (fold it away instead)
  SRef add(std::vector<SRef> terms);
  SRef mul(std::vector<SRef> factors);
  SRef div(SRef numerator, SRef denominator);
  SRef sin(SRef angle);
  SRef cos(SRef angle);
  SRef tanh(SRef x);
  SRef exp(SRef x);
  SRef pow(SRef base, int exponent);         // only in unshared programs (the baseline prints pow)
  SRef zero() const { return {-1, false}; }  // id -1: the constant 0

  // Greedy common-pair extraction over all sums and products reachable from roots.
  void extract_common_pairs(const std::vector<SRef>& roots);

  // Nodes reachable from roots in an order where operands come first.
  std::vector<int> schedule(const std::vector<SRef>& roots) const;
  OpCounts count(const std::vector<SRef>& roots) const;
  // Numeric value of each root, inputs looked up by array name and index (self-checks).
  std::vector<double> evaluate(
      const std::vector<SRef>& roots,
      const std::function<double(const std::string&, int)>& input_value) const;
  // The same over `order`, schedule(roots) computed once, for repeated evaluation.
  std::vector<double> evaluate(
      const std::vector<int>& order, const std::vector<SRef>& roots,
      const std::function<double(const std::string&, int)>& input_value) const;

  const Node& node(int id) const { return nodes_[id]; }
  size_t size() const { return nodes_.size(); }

 private:
  SRef intern(Node node);
  void extract_pass(Kind kind, const std::vector<SRef>& roots);
  bool share_ = true;
  std::vector<Node> nodes_;
  std::map<std::tuple<int, std::vector<SRef>, std::string, int>, int> index_;
};

}  // namespace spacearm
