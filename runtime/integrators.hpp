// Integrators, so that users can trade speed for accuracy:
//   rk4                fixed step, classical Runge-Kutta (the paper's Simulink "ode4")
//   dopri5             adaptive Dormand-Prince 5(4), error control, dense output
//   rkf78              adaptive Runge-Kutta-Fehlberg 7(8), for reference solutions
//   implicit_midpoint  fixed step, symplectic and symmetric, for long horizons
// The explicit methods are Boost.Odeint's (with Eigen fixed-size states). Odeint has no
// implicit midpoint rule for a general (non-separable) system, so that one is written
// here: a simplified Newton iteration with a finite-difference Jacobian per step.
#pragma once

#include <Eigen/Core>
#include <Eigen/LU>
#include <boost/numeric/odeint.hpp>
#include <boost/numeric/odeint/external/eigen/eigen.hpp>

#include <cmath>
#include <functional>
#include <stdexcept>
#include <string>

namespace spacearm {

enum class Method { rk4, dopri5, rkf78, implicit_midpoint };

inline Method method_from_string(const std::string& name) {
  if (name == "rk4") return Method::rk4;
  if (name == "dopri5") return Method::dopri5;
  if (name == "rkf78") return Method::rkf78;
  if (name == "implicit_midpoint") return Method::implicit_midpoint;
  throw std::invalid_argument("unknown integrator '" + name + "' (known: rk4, dopri5, rkf78, implicit_midpoint)");
}
inline std::string to_string(Method m) {
  switch (m) {
    case Method::rk4: return "rk4";
    case Method::dopri5: return "dopri5";
    case Method::rkf78: return "rkf78";
    case Method::implicit_midpoint: return "implicit_midpoint";
  }
  return "?";
}

struct IntegratorOptions {
  Method method = Method::rk4;
  double dt = 0.01;      // step of the fixed-step methods
  double rtol = 1e-8;    // tolerances of the adaptive methods
  double atol = 1e-10;
};

template <class State, class Rhs>
void implicit_midpoint_step(Rhs&& rhs, State& x, double t, double h);

struct IntegrationStats {
  long rhs_evaluations = 0;
};

// Integrates dx/dt = f(x, t) from t0 to t1, calling observe(x, t) at t0 + k * dt_out
// (and at t1). The fixed-step methods need dt_out to be a multiple of opt.dt.
template <class State, class System, class Observer>
IntegrationStats integrate(const IntegratorOptions& opt, System&& f, State& x, double t0, double t1, double dt_out,
                           Observer&& observe) {
  namespace odeint = boost::numeric::odeint;
  IntegrationStats stats;
  auto rhs = [&](const State& s, State& dsdt, double t) {
    ++stats.rhs_evaluations;
    f(s, dsdt, t);
  };
  const long outputs = std::lround((t1 - t0) / dt_out);
  if (outputs < 1 || std::abs(t0 + outputs * dt_out - t1) > 1e-9 * std::max(1.0, std::abs(t1)))
    throw std::invalid_argument("integrate: (t1 - t0) = " + std::to_string(t1 - t0) +
                                " must be a positive multiple of dt_out = " + std::to_string(dt_out));
  auto check_fixed = [&] {
    const long per = std::lround(dt_out / opt.dt);
    if (per < 1 || std::abs(per * opt.dt - dt_out) > 1e-9 * dt_out)
      throw std::invalid_argument("integrate: dt_out = " + std::to_string(dt_out) +
                                  " must be a multiple of the step dt = " + std::to_string(opt.dt));
    return per;
  };
  observe(x, t0);
  switch (opt.method) {
    case Method::rk4: {
      const long per = check_fixed();
      odeint::runge_kutta4<State, double, State, double, odeint::vector_space_algebra> stepper;
      for (long k = 0; k < outputs; ++k) {
        for (long s = 0; s < per; ++s) stepper.do_step(rhs, x, t0 + (k * per + s) * opt.dt, opt.dt);
        observe(x, t0 + (k + 1) * dt_out);
      }
      break;
    }
    case Method::dopri5: {
      // Dense output: steps of the controller's own size, states at the outputs by the
      // method's continuous extension.
      auto stepper = odeint::make_dense_output(
          opt.atol, opt.rtol, odeint::runge_kutta_dopri5<State, double, State, double, odeint::vector_space_algebra>());
      stepper.initialize(x, t0, std::min(dt_out, 0.01));
      State out = x;
      for (long k = 1; k <= outputs; ++k) {
        const double t_out = t0 + k * dt_out;
        while (stepper.current_time() < t_out) stepper.do_step(rhs);
        stepper.calc_state(t_out, out);
        observe(out, t_out);
      }
      x = out;
      break;
    }
    case Method::rkf78: {
      // Controlled steps; the step size the controller chose is kept across outputs (a step
      // shortened to land on an output time does not shrink the next one).
      auto stepper = odeint::make_controlled(
          opt.atol, opt.rtol,
          odeint::runge_kutta_fehlberg78<State, double, State, double, odeint::vector_space_algebra>());
      double dt = std::min(dt_out, 0.01), t = t0;
      for (long k = 1; k <= outputs; ++k) {
        const double t_out = t0 + k * dt_out;
        int rejected = 0;
        while (t < t_out - 1e-12 * std::max(1.0, std::abs(t_out))) {
          const double natural = dt;
          const bool clamped = t + dt > t_out;
          double step = clamped ? t_out - t : dt;
          if (stepper.try_step(rhs, x, t, step) == odeint::success) {
            rejected = 0;
            dt = clamped ? std::max(natural, step) : step;
          } else {
            dt = step;
            if (++rejected > 500 || dt < 1e-14 * std::max(1.0, std::abs(t)))
              throw std::runtime_error("rkf78: step size underflow at t = " + std::to_string(t) +
                                       " (tolerance cannot be met)");
          }
        }
        t = t_out;
        observe(x, t_out);
      }
      break;
    }
    case Method::implicit_midpoint: {
      const long per = check_fixed();
      for (long k = 0; k < outputs; ++k) {
        for (long s = 0; s < per; ++s) implicit_midpoint_step(rhs, x, t0 + (k * per + s) * opt.dt, opt.dt);
        observe(x, t0 + (k + 1) * dt_out);
      }
      break;
    }
  }
  return stats;
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
  for (int it = 0; it < 50; ++it) {
    State fk(x.size());
    rhs(State(x + (h / 2) * k), fk, tm);
    const State delta = lu.solve(fk - k);
    k += delta;
    if (!k.allFinite()) break;
    if (delta.norm() <= 1e-14 * std::max(1.0, k.norm())) {
      x += h * k;
      return;
    }
  }
  throw std::runtime_error("implicit midpoint: Newton iteration did not converge at t = " + std::to_string(t) +
                           " (step " + std::to_string(h) + ")");
}

}  // namespace spacearm
