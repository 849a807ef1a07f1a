// The checks every forward-dynamics path shares (the fixed-size Model<G> of linked code and
// the dynamic-size CompiledModel of loaded code): a failure is a DynamicsError saying what,
// never a silently wrong acceleration.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>

#include "text_numbers.hpp"

namespace spacearm {

// A failure of the dynamics at run time (bad input, mass matrix not positive definite);
// the message says what, where (time, state) is added by the caller that knows it.
class DynamicsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Every entry of every vector is finite: x - x is 0 for a finite x and NaN otherwise, so one
// sum tests them all. On the path every call takes, this costs less than allFinite's compare
// and branch per vector (FD of a 3-link chain: 2 ns against 9 ns).
// Under -ffast-math (finite math assumed) that sum would always be 0: Eigen's allFinite, which
// tests the bits there.
template <class... Vectors>
bool all_finite(const Vectors&... v) {
#if defined(__FINITE_MATH_ONLY__) && __FINITE_MATH_ONLY__
  return (v.allFinite() && ...);
#else
  return ((v - v).sum() + ...) == 0;
#endif
}

// The same for n doubles at v: x * 0 is 0 for a finite x and NaN for inf or NaN, in four
// partial sums so that the additions do not wait for each other (one sum over many entries is a
// chain of dependent additions: a third of a batch's time per state).
inline bool all_finite_array(const double* v, long n) {
#if defined(__FINITE_MATH_ONLY__) && __FINITE_MATH_ONLY__
  return Eigen::Map<const Eigen::ArrayXd>(v, n).allFinite();
#else
  double a[4] = {0, 0, 0, 0};
  long i = 0;
  for (; i + 4 <= n; i += 4)
    for (int k = 0; k < 4; ++k) a[k] += v[i + k] * 0.0;
  for (; i < n; ++i) a[0] += v[i] * 0.0;
  return (a[0] + a[1]) + (a[2] + a[3]) == 0;
#endif
}

// Forward dynamics' inputs must be finite: a DynamicsError names every entry that is not
// (coordinate_names: the nq names of q). The model's name is a view: the checks run on every
// call and build a string only to fail (a name past 15 characters would allocate each call).
template <class Config, class Velocity, class Names>
void check_finite_inputs(const Config& q, const Velocity& qd, const Velocity& Q,
                         std::string_view model_name, const Names& coordinate_names) {
  if (all_finite(q, qd, Q)) return;
  std::ostringstream msg;
  msg << "model " << model_name << ": non-finite input";
  for (Eigen::Index i = 0; i < q.size(); ++i)
    if (!std::isfinite(q[i])) msg << " q[" << i << "] (" << coordinate_names[i] << ") = " << q[i];
  for (Eigen::Index i = 0; i < qd.size(); ++i) {
    if (!std::isfinite(qd[i])) msg << " qd[" << i << "] = " << qd[i];
    if (!std::isfinite(Q[i])) msg << " Q[" << i << "] = " << Q[i];
  }
  throw DynamicsError(msg.str());
}

// Largest condition number of diag(M)^-1/2 M diag(M)^-1/2 for which a double solve still
// has correct digits.
inline constexpr double kMaxScaledCondition = 1e14;

// One entry of check_forward_dynamics' test below: a pivot D_i and its scaled pivot D_i / M_ii,
// positive, finite and the scaled one above 1 / kMaxScaledCondition (no inf or NaN passes).
inline bool pivot_within_bounds(double d, double scaled) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  return (d > 0) & (d < inf) & (scaled > 1 / kMaxScaledCondition) & (scaled < inf);
}

// The same test on n pairs (d[i], scaled[i]). Two at a time in SSE2 registers (every x86-64
// has them): one comparison each and no branch per entry, where the scalar loop's four
// comparisons and flags per entry took a tenth of a checked 4-lane batch's time.
inline bool all_pivots_within_bounds(const double* d, const double* scaled, long n) {
  long i = 0;
  bool ok = true;
#if defined(__SSE2__)
  const __m128d zero = _mm_setzero_pd(), inf = _mm_set1_pd(std::numeric_limits<double>::infinity()),
                floor = _mm_set1_pd(1 / kMaxScaledCondition);
  __m128d all = _mm_castsi128_pd(_mm_set1_epi64x(-1));
  for (; i + 2 <= n; i += 2) {
    const __m128d a = _mm_loadu_pd(d + i), b = _mm_loadu_pd(scaled + i);
    all = _mm_and_pd(all, _mm_and_pd(_mm_and_pd(_mm_cmpgt_pd(a, zero), _mm_cmplt_pd(a, inf)),
                                     _mm_and_pd(_mm_cmpgt_pd(b, floor), _mm_cmplt_pd(b, inf))));
  }
  ok = _mm_movemask_pd(all) == 3;
#endif
  for (; i < n; ++i) ok &= pivot_within_bounds(d[i], scaled[i]);
  return ok;
}

// pivots: D_i of M = L D L^T; all positive exactly when M is positive definite.
// scaled_pivots: D_i / M_ii, the pivots of diag(M)^-1/2 M diag(M)^-1/2. Cholesky/LDL^T is
// invariant under symmetric diagonal scaling (van der Sluis): its accuracy depends on
// cond(S M S), S = diag(M)^-1/2, not on cond(M), which grows as p^2 in motor coordinates
// without any loss of accuracy. max/min of the scaled pivots is a cheap lower bound of
// cond(S M S); past kMaxScaledCondition no digit of the solve is left. The scaled pivots are
// at most 1 (each D_i is a Schur complement of M_ii) and the first one factored is 1 (its D is
// its M_ii), so the bound is min > 1 / that: one comparison per entry on the path every call
// takes, no min/max (which ran after the solve's last operation and cost the 3-link chain's FD
// 15 ns, a tenth of its time).
template <class Pivots, class Acceleration>
void check_forward_dynamics(const Pivots& pivots, const Pivots& scaled_pivots,
                            const Acceleration& qdd, std::string_view model_name) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  const auto d = pivots.array(), s = scaled_pivots.array();
  bool ok = (d > 0 && d < inf && s > 1 / kMaxScaledCondition && s < inf).all() && all_finite(qdd);
#if defined(__FINITE_MATH_ONLY__) && __FINITE_MATH_ONLY__
  ok = ok && all_finite(pivots, scaled_pivots);  // the comparisons above cannot see inf or NaN
#endif
  if (ok) return;
  // The test above failed: which check, in order.
  if (!all_finite(pivots, scaled_pivots) || !(pivots.minCoeff() > 0))
    throw DynamicsError("model " + std::string(model_name) +
                        ": mass matrix is not positive definite");
  const double lo = scaled_pivots.minCoeff(), hi = scaled_pivots.maxCoeff();
  if (!(lo > 1 / kMaxScaledCondition))
    throw DynamicsError(
        "model " + std::string(model_name) +
        ": mass matrix numerically singular (condition number of the diagonally scaled matrix >= " +
        number_text(hi / lo, 3) + ")");
  throw DynamicsError("model " + std::string(model_name) + ": accelerations not finite (overflow)");
}

// The pivots D_i = L_ii^2 and D_i / M_ii of a Cholesky factorization M = L L^T, for the
// paths that solve with Eigen's LLT instead of the emitted LDL^T.
template <class Llt, class Matrix, class Vector>
void llt_pivots(const Llt& llt, const Matrix& M, Vector& pivots, Vector& scaled_pivots) {
  pivots = llt.matrixLLT().diagonal().array().square();
  scaled_pivots = pivots.cwiseQuotient(M.diagonal());
}

// qdd = M^-1 rhs by Eigen's Cholesky factorization, with its pivots: the one forward-dynamics
// fallback of a model that emits no forward_dynamics (linked or loaded alike). A DynamicsError
// where M is not positive definite.
template <class Matrix, class Vector>
Vector cholesky_forward_dynamics(const Matrix& M, const Vector& rhs, std::string_view model_name,
                                 Vector& pivots, Vector& scaled_pivots) {
  const Eigen::LLT<Matrix> llt(M);
  if (llt.info() != Eigen::Success)
    throw DynamicsError("model " + std::string(model_name) +
                        ": mass matrix is not positive definite");
  llt_pivots(llt, M, pivots, scaled_pivots);
  return llt.solve(rhs);
}

}  // namespace spacearm
