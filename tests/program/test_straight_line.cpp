// generator/program/straight_line.hpp: the program IR's common-subexpression elimination, tested
// directly. Identical nodes are made once (hash-consing, sums and products in any operand
// order); the greedy pair extraction factors out what several sums and products share, lowering
// the operation count while every root keeps its value at random inputs; an unshared program
// (the plain baseline) keeps every copy.
#include "straight_line.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

namespace spacearm {
namespace {

// Roots over inputs x0..x3 where the pairs x0*x1 and (x2 + x3) appear in several places.
std::vector<SRef> shared_pairs(Program& p) {
  const SRef x0 = p.input("x", 0), x1 = p.input("x", 1), x2 = p.input("x", 2), x3 = p.input("x", 3);
  return {p.mul({x0, x1, x2}), p.mul({x1, x0, x3}), p.mul({x0, x1, p.sin(x3)}),
          p.add({x2, x3, x0}), p.add({x3, x2, x1}), p.add({x2, -x3, p.mul({x0, x1})})};
}

std::vector<double> values_at(const Program& p, const std::vector<SRef>& roots,
                              const std::vector<double>& x) {
  return p.evaluate(roots, [&x](const std::string&, int i) { return x.at(size_t(i)); });
}

TEST(StraightLine, IdenticalNodesAreMadeOnceInAnyOperandOrder) {
  Program p;
  const SRef a = p.input("x", 0), b = p.input("x", 1);
  EXPECT_EQ(p.input("x", 0), a);
  EXPECT_EQ(p.mul({a, b}), p.mul({b, a}));
  EXPECT_EQ(p.add({a, b}), p.add({b, a}));
  EXPECT_EQ(p.sin(a), p.sin(a));
  EXPECT_EQ(p.constant(0.5), p.constant(0.5));
  EXPECT_EQ(p.constant(-0.5), -p.constant(0.5));
  const size_t before = p.size();
  p.mul({b, a});
  EXPECT_EQ(p.size(), before);
  // The baseline's program shares nothing: the same product is a new node.
  Program plain(false);
  const SRef c = plain.input("x", 0), d = plain.input("x", 1);
  EXPECT_NE(plain.mul({c, d}).id, plain.mul({c, d}).id);
}

TEST(StraightLine, CommonPairsAreFactoredOutAndValuesKept) {
  Program p;
  const std::vector<SRef> roots = shared_pairs(p);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-2, 2);
  std::vector<std::vector<double>> states, before;
  for (int k = 0; k < 5; ++k) {
    states.push_back({u(rng), u(rng), u(rng), u(rng)});
    before.push_back(values_at(p, roots, states.back()));
  }
  const OpCounts ops_before = p.count(roots);
  p.extract_common_pairs(roots);
  const OpCounts ops_after = p.count(roots);
  // x0*x1 in three products (and one sum's term), x2 + x3 in two sums: each made once.
  EXPECT_LT(ops_after.total_arithmetic(), ops_before.total_arithmetic());
  EXPECT_LE(ops_after.muls, ops_before.muls - 2);
  EXPECT_LE(ops_after.adds, ops_before.adds - 1);
  EXPECT_EQ(ops_after.trig, ops_before.trig);
  for (size_t k = 0; k < states.size(); ++k) {
    const std::vector<double> after = values_at(p, roots, states[k]);
    for (size_t r = 0; r < roots.size(); ++r)
      EXPECT_NEAR(after[r], before[k][r], 1e-14 * std::max(1.0, std::abs(before[k][r])))
          << "root " << r;
  }
}

TEST(StraightLine, AScheduleListsOperandsBeforeTheirUsers) {
  Program p;
  const std::vector<SRef> roots = shared_pairs(p);
  p.extract_common_pairs(roots);
  const std::vector<int> order = p.schedule(roots);
  std::vector<int> position(p.size(), -1);
  for (size_t k = 0; k < order.size(); ++k) position[size_t(order[k])] = int(k);
  for (int id : order)
    for (const SRef& a : p.node(id).args)
      if (a.id >= 0) {
        EXPECT_LT(position[size_t(a.id)], position[size_t(id)]) << id;
      }
  for (const SRef& r : roots) EXPECT_GE(position[size_t(r.id)], 0);
}

}  // namespace
}  // namespace spacearm
