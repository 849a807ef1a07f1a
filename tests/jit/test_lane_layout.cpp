// jit/lane_layout.hpp: four states into the lanes of a 4-lane function and back, the register
// transpose (AVX2, where the CPU has it) moving exactly what the portable loops move, for every
// n up to three blocks and a remainder; an entry that is not finite, wherever it sits, is seen
// both ways.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "dynamics_checks.hpp"
#include "lane_layout.hpp"

namespace spacearm::lanes {
namespace {

std::vector<double> random_states(int n, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1e3, 1e3);
  std::vector<double> x(4 * n);
  for (double& v : x) v = u(rng);
  return x;
}

TEST(LaneLayout, MovesWhatThePortableLoopsMove) {
  std::mt19937 rng(7);
  for (int n = 1; n <= 15; ++n) {
    SCOPED_TRACE(n);
    const std::vector<double> x = random_states(n, rng);
    std::vector<double> lane(4 * n), portable(4 * n), back(4 * n);
    EXPECT_TRUE(interleave(x.data(), n, lane.data()));
    EXPECT_TRUE(interleave_portable(x.data(), n, portable.data()));
    EXPECT_EQ(lane, portable);
    for (int j = 0; j < n; ++j)
      for (int l = 0; l < 4; ++l) ASSERT_EQ(lane[4 * j + l], x[l * n + j]);
    EXPECT_TRUE(deinterleave(lane.data(), n, back.data()));
    EXPECT_EQ(back, x);
  }
}

TEST(LaneLayout, SeesEveryEntryThatIsNotFinite) {
  std::mt19937 rng(8);
  const double bad[] = {std::numeric_limits<double>::quiet_NaN(),
                        std::numeric_limits<double>::infinity(),
                        -std::numeric_limits<double>::infinity()};
  for (int n : {1, 3, 4, 6, 9}) {
    for (int at = 0; at < 4 * n; ++at) {
      for (double b : bad) {
        std::vector<double> x = random_states(n, rng), lane(4 * n);
        x[at] = b;
        EXPECT_FALSE(interleave(x.data(), n, lane.data())) << "n " << n << " at " << at;
        EXPECT_FALSE(interleave_portable(x.data(), n, lane.data()));
        std::vector<double> states(4 * n);
        EXPECT_FALSE(deinterleave(x.data(), n, states.data())) << "n " << n << " at " << at;
        EXPECT_FALSE(deinterleave_portable(x.data(), n, states.data()));
      }
    }
  }
  // Finite entries whose sum would overflow are finite.
  std::vector<double> x(4 * 4, 1.7e308), lane(16);
  EXPECT_TRUE(interleave(x.data(), 4, lane.data()));
  EXPECT_TRUE(deinterleave(lane.data(), 4, x.data()));
}

// The pivot test four pairs at a time says what all_pivots_within_bounds says, for every n up to
// seven registers and a remainder, with a pivot or a scaled pivot out of bounds anywhere.
TEST(LaneLayout, PivotTestIsAllPivotsWithinBounds) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(0.01, 1.0);
  const double inf = std::numeric_limits<double>::infinity();
  const double bad[] = {0.0, -1.0, inf, std::numeric_limits<double>::quiet_NaN(),
                        0.5 / kMaxScaledCondition};
  for (long n = 1; n <= 30; ++n) {
    std::vector<double> d(n), scaled(n);
    for (long i = 0; i < n; ++i) d[i] = 1e3 * u(rng), scaled[i] = u(rng);
    EXPECT_TRUE(pivots_within_bounds(d.data(), scaled.data(), n)) << n;
    for (long at = 0; at < n; ++at)
      for (double b : bad)
        for (std::vector<double>* v : {&d, &scaled}) {
          const double kept = (*v)[at];
          (*v)[at] = b;
          const bool expected = all_pivots_within_bounds(d.data(), scaled.data(), n);
          EXPECT_EQ(pivots_within_bounds(d.data(), scaled.data(), n), expected)
              << "n " << n << " at " << at << " value " << b;
          // Every bad value fails one of the two tests, but a small pivot is a good pivot.
          EXPECT_EQ(expected, v == &d && b == 0.5 / kMaxScaledCondition);
          (*v)[at] = kept;
        }
  }
}

}  // namespace
}  // namespace spacearm::lanes
