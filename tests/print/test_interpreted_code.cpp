// generator/print/interpreted_code.hpp: printed statements read as C++ reads them (left to right,
// unary minus, literals, sincos batches, symmetric copies), negations folded into sums with the
// same bits, and registers reused without a value overwriting one still to be read. The bit
// equality with compiled code on every kept scene is tests/jit/test_interpreter.cpp's.
#include <cmath>
#include <cstring>

#include "interpreted_code.hpp"
#include "interpreter.hpp"
#include "support.hpp"

namespace spacearm {
namespace {

// Runs one printed body over q (3 entries) and params (1), returning result 0's entries.
std::vector<double> run(const std::string& body, int results, std::vector<double> q,
                        double param = 2.0) {
  const InterpretedFunction f =
      interpreted_statements("f", {"q"}, {3}, 1, body, std::vector<int>{results});
  std::vector<double> out(results, -99.0);
  const double* in[] = {q.data()};
  double* res[] = {out.data()};
  interpret(f, {}, in, &param, res);
  return out;
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

TEST(InterpretedCode, SumsAndProductsGroupFromTheLeftAsInCpp) {
  // 1e16 + 1 + 1 is (1e16 + 1) + 1 = 1e16 in doubles; grouped from the right it is 1e16 + 2.
  const auto r =
      run("  out[0][0] = q[0] + q[1] + q[2];\n  out[0][1] = q[0] + (q[1] + q[2]);\n"
          "  out[0][2] = q[0] * q[1] / q[2] * T(3);\n",
          3, {1e16, 1, 1});
  EXPECT_EQ(r[0], 1e16);
  EXPECT_EQ(r[1], 1e16 + 2);
  EXPECT_TRUE(same_bits(r[2], 1e16 * 1 / 1 * 3.0));
}

TEST(InterpretedCode, NegationsFoldIntoSumsWithTheSameBits) {
  // A temporary read once, negated, by a sum: (a + -t), (a - -t), (-t + a); tanh is always named.
  const std::vector<double> q = {0.3, -1.7, 0.25};
  const auto r =
      run("  const T t0 = tanh(q[0]);\n  const T t1 = exp(q[1]);\n  const T t2 = tanh(q[2]);\n"
          "  out[0][0] = T(1) + -t0;\n  out[0][1] = q[1] - -t1;\n  out[0][2] = -t2 + q[0];\n"
          "  out[0][3] = -(q[0] * q[1]) + params[0];\n",
          4, q);
  EXPECT_TRUE(same_bits(r[0], 1.0 + -std::tanh(q[0])));
  EXPECT_TRUE(same_bits(r[1], q[1] - -std::exp(q[1])));
  EXPECT_TRUE(same_bits(r[2], -std::tanh(q[2]) + q[0]));
  EXPECT_TRUE(same_bits(r[3], -(q[0] * q[1]) + 2.0));
}

TEST(InterpretedCode, SinesInBatchesAndCopiesOfSymmetricEntries) {
  const std::vector<double> q = {0.3, -1.2, 2.5};
  const auto r =
      run("  const T angles0[5] = {q[0], q[1], q[2], q[0] + q[1], -q[2]};\n"
          "  T sines0[5], cosines0[5];\n  sincos_batch(angles0, sines0, cosines0);\n"
          "  out[0][0] = sines0[0] * cosines0[4];\n  out[0][2] = sines0[3] - cosines0[1];\n"
          "  out[0][1] = out[0][2];\n  out[0][3] = sines0[4];\n",
          4, q);
  EXPECT_TRUE(same_bits(r[0], std::sin(q[0]) * std::cos(-q[2])));
  EXPECT_TRUE(same_bits(r[2], std::sin(q[0] + q[1]) - std::cos(q[1])));
  EXPECT_TRUE(same_bits(r[1], r[2]));
  EXPECT_TRUE(same_bits(r[3], std::sin(-q[2])));
}

TEST(InterpretedCode, WhatItCannotReadIsALogicErrorNamingTheFunction) {
  for (const char* body :
       {"  out[0][0] = q[7];\n", "  out[0][0] = t9;\n", "  out[0][0] = q[0] +;\n",
        "  out[0][0] = T(1.5x);\n", "  return q[0];\n"}) {
    try {
      run(body, 1, {1, 2, 3});
      ADD_FAILURE() << body;
    } catch (const std::logic_error& e) {
      EXPECT_NE(std::string(e.what()).find("function f"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace spacearm
