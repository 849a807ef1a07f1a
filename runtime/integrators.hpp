// Integrators, so that users can trade speed for accuracy:
//   rk4                fixed step, classical Runge-Kutta (the paper's Simulink "ode4")
//   dopri5             adaptive Dormand-Prince 5(4), error control, dense output
//   rkf78              adaptive Runge-Kutta-Fehlberg 7(8), for reference solutions
//   implicit_midpoint  fixed step, implicit, symmetric (time-reversible), second order. It
//                      is applied to (q, qd), not to canonical (q, p = M qd), so it is not
//                      symplectic here and does not conserve momentum exactly.
//   rosenbrock4        adaptive, linearly implicit, L-stable, order 4 (Hairer and Wanner's
//                      RODAS coefficients), for stiff systems (flexible joints, steep friction):
//                      needs the exact Jacobian of the right-hand side (options.jacobian).
// The explicit methods and rosenbrock4 are Boost.Odeint's (Eigen states; rosenbrock4 works
// on uBLAS and is adapted here). Odeint has no implicit midpoint rule for a general
// (non-separable) system, so that one is written here: a simplified Newton iteration with
// a finite-difference Jacobian per step.
#pragma once

#include <Eigen/Core>
#include <Eigen/LU>

#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>
#include <type_traits>

#include "integrator_options.hpp"
#include "integrators_detail.hpp"

namespace spacearm {

using DynamicSystem =
    std::function<void(const Eigen::VectorXd& x, Eigen::VectorXd& dxdt, double t)>;
using DynamicObserver = std::function<void(const Eigen::VectorXd& x, double t)>;

// integrate() on run-time-sized states (every DynamicModel), compiled once in the runtime
// library (integrators.cpp) rather than in every file that integrates: the methods' code is
// most of such a file's compile time. f and observe are called through std::function, an
// indirect call per evaluation next to the hundreds of operations of the dynamics.
IntegrationStats integrate_dynamic(const IntegratorOptions& opt, const DynamicSystem& f,
                                   Eigen::VectorXd& x, double t0, double t1, double dt_out,
                                   const DynamicObserver& observe);

// Integrates dx/dt = f(x, t) from t0 to t1, calling observe(x, t) at t0 + k * dt_out
// (and at t1). The fixed-step methods need dt_out to be a multiple of opt.dt.
template <class State, class System, class Observer>
IntegrationStats integrate(const IntegratorOptions& opt, System&& f, State& x, double t0, double t1,
                           double dt_out, Observer&& observe) {
  if constexpr (std::is_same_v<State, Eigen::VectorXd>) {
    // std::ref: the std::functions refer to f and observe, never copying (or allocating).
    return integrate_dynamic(opt, DynamicSystem(std::ref(f)), x, t0, t1, dt_out,
                             DynamicObserver(std::ref(observe)));
  } else {
    return detail::integrate_states(opt, f, x, t0, t1, dt_out, observe);
  }
}

// One step of the implicit midpoint rule x1 = x0 + h f((x0 + x1)/2, t + h/2), solved by
// simplified Newton on k = (x1 - x0)/h with the Jacobian of f by forward differences.
template <class State, class Rhs>
void implicit_midpoint_step(Rhs&& rhs, State& x, double t, double h) {
  constexpr int N = State::RowsAtCompileTime;  // Eigen::Dynamic for run-time sizes
  using Matrix = Eigen::Matrix<double, N, N>;
  const int n = static_cast<int>(x.size());
  const double tm = t + h / 2;
  State k(x.size()), f0(x.size());
  rhs(x, k, tm);  // explicit guess
  f0 = k;
  Matrix J(n, n);
  for (int j = 0; j < n; ++j) {
    State xp = x;
    const double e = 1e-7 * std::max(1.0, std::abs(x[j]));
    xp[j] += e;
    State fp(x.size());
    rhs(xp, fp, tm);
    J.col(j) = (fp - f0) / e;
  }
  const Eigen::PartialPivLU<Matrix> lu(Matrix::Identity(n, n) - (h / 2) * J);
  double previous = std::numeric_limits<double>::infinity();
  for (int it = 0; it < 50; ++it) {
    State fk(x.size());
    rhs(State(x + (h / 2) * k), fk, tm);
    const State delta = lu.solve(fk - k);
    k += delta;
    if (!k.allFinite()) break;
    // Converged: the update is at rounding level, or it stopped shrinking while already
    // tiny (the iteration has reached the rounding floor of f, which can lie above 1e-14).
    const double size = delta.norm(), scale = std::max(1.0, k.norm());
    if (size <= 1e-14 * scale || (size >= previous && size <= 1e-10 * scale)) {
      x += h * k;
      return;
    }
    previous = size;
  }
  throw std::runtime_error("implicit midpoint: Newton iteration did not converge at t = " +
                           detail::format(t, 10) + " (step " + detail::format(h, 10) + ")");
}

}  // namespace spacearm
