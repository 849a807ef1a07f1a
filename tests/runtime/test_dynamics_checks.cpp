// The per-call checks of forward dynamics (runtime/dynamics_checks.hpp): the quick test that
// every call runs passes exactly when no detailed check would fail, and each failure names
// what went wrong.
#include "dynamics_checks.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "support.hpp"

namespace spacearm {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
using Vector3 = Eigen::Vector3d;

TEST(DynamicsChecks, AllFiniteFindsEveryNonFiniteEntry) {
  const Vector3 ok(1e308, -1e308, 0);  // their sum overflows; each entry is finite
  EXPECT_TRUE(all_finite(ok, ok, Eigen::VectorXd(Eigen::VectorXd::Zero(0))));
  for (double bad : {kInf, -kInf, kNaN})
    for (int i = 0; i < 3; ++i) {
      Vector3 v = ok;
      v[i] = bad;
      EXPECT_FALSE(all_finite(ok, v)) << "entry " << i << " = " << bad;
    }
}

// The test on many pairs at once (two per SSE2 register) is the test on each pair: every value
// at either side of each bound, at every position of arrays of odd and even length.
TEST(DynamicsChecks, AllPivotsWithinBoundsIsEachPairsTest) {
  const double floor = 1 / kMaxScaledCondition;
  const std::array<double, 11> values{0.0,   -0.0, -1.0,  1.0,  floor, std::nextafter(floor, 1.0),
                                      1e308, kInf, -kInf, kNaN, 5e-324};
  for (int n = 1; n <= 7; ++n)
    for (int at = 0; at < n; ++at)
      for (double v : values)
        for (bool in_scaled : {false, true}) {
          std::vector<double> d(n, 2.0), scaled(n, 0.5);
          (in_scaled ? scaled : d)[at] = v;
          bool each = true;
          for (int i = 0; i < n; ++i) each &= pivot_within_bounds(d[i], scaled[i]);
          EXPECT_EQ(all_pivots_within_bounds(d.data(), scaled.data(), n), each)
              << "n " << n << ", " << (in_scaled ? "scaled" : "d") << "[" << at << "] = " << v;
        }
  EXPECT_TRUE(all_pivots_within_bounds(nullptr, nullptr, 0));
}

TEST(DynamicsChecks, InputsNameTheNonFiniteEntry) {
  const std::array<const char*, 3> names{"x", "y", "q1"};
  const Vector3 ok(0.1, 0.2, 0.3);
  Vector3 q = ok;
  q[2] = kNaN;
  EXPECT_THROW_MESSAGE(check_finite_inputs(q, ok, ok, "m", names), DynamicsError,
                       "q[2] (q1) = nan");
  Vector3 Q = ok;
  Q[0] = -kInf;
  EXPECT_THROW_MESSAGE(check_finite_inputs(ok, ok, Q, "m", names), DynamicsError, "Q[0] = -inf");
  EXPECT_NO_THROW(check_finite_inputs(ok, ok, ok, "m", names));
}

// Scaled pivots D_i / M_ii are at most 1; the solve is refused when one falls to
// 1 / kMaxScaledCondition or below.
TEST(DynamicsChecks, ForwardDynamicsFailuresSayWhich) {
  const Vector3 qdd(1, 2, 3), pivots(4, 2, 1);
  const double edge = 1 / kMaxScaledCondition;
  EXPECT_NO_THROW(check_forward_dynamics(pivots, Vector3(1, 0.5, 2 * edge), qdd, "m"));
  for (double bad : {0.0, -1.0, kNaN, kInf})
    EXPECT_THROW_MESSAGE(check_forward_dynamics(Vector3(4, bad, 1), Vector3(1, 0.5, 0.1), qdd, "m"),
                         DynamicsError, "m: mass matrix is not positive definite");
  EXPECT_THROW_MESSAGE(check_forward_dynamics(pivots, Vector3(1, kNaN, 0.1), qdd, "m"),
                       DynamicsError, "not positive definite");
  EXPECT_THROW_MESSAGE(check_forward_dynamics(pivots, Vector3(1, 0.5, edge), qdd, "m"),
                       DynamicsError, "numerically singular (condition number");
  EXPECT_THROW_MESSAGE(check_forward_dynamics(pivots, Vector3(1, 0.5, edge / 2), qdd, "m"),
                       DynamicsError, ">= 2");
  for (double bad : {kInf, kNaN})
    EXPECT_THROW_MESSAGE(
        check_forward_dynamics(pivots, Vector3(1, 0.5, 0.1), Vector3(0, bad, 0), "m"),
        DynamicsError, "accelerations not finite");
}

}  // namespace
}  // namespace spacearm
