// The stepping loops behind integrate() (integrators.hpp), on Boost.Odeint's steppers: the checks
// of the options, the loops of the explicit, implicit and Rosenbrock methods, the error checker and
// the Rosenbrock stepper adapted to Eigen states. Internals: include integrators.hpp.
#pragma once

#include <Eigen/Core>
#include <Eigen/LU>
#include <boost/numeric/odeint.hpp>
#include <boost/numeric/odeint/external/eigen/eigen.hpp>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "integrator_options.hpp"
#include "text_numbers.hpp"

namespace spacearm {

// One step of the implicit midpoint rule (defined in integrators.hpp).
template <class State, class Rhs>
void implicit_midpoint_step(Rhs&& rhs, State& x, double t, double h);

namespace detail {
inline std::string format(double v, int digits = 3) { return number_text(v, digits); }
template <class State>
IntegrationError integration_error(Method m, const std::string& why, double t, const State& x) {
  std::ostringstream msg;
  msg.precision(17);
  msg << to_string(m) << ": " << why << "; last accepted state at t = " << t << ": [";
  for (Eigen::Index i = 0; i < x.size(); ++i) msg << (i ? ", " : "") << x[i];
  msg << "]";
  return IntegrationError(msg.str(), t, Eigen::VectorXd(x));
}
// Smallest step allowed: 16 ulps of the largest time in the span (MATLAB's ode45 rule, with
// the span's end instead of t so that it is not zero at t = 0). Below it a controller is
// only chasing rounding, and t barely advances.
// FSAL steppers (dopri5) reuse the last stage of a step as the first of the next: after a
// step that lands on a breakpoint the right-hand side may jump there (a held torque), so
// the first stage must be evaluated anew.
template <class Stepper>
auto reset_first_same_as_last(Stepper& s, int) -> decltype(s.reset(), void()) {
  s.reset();
}
template <class Stepper>
void reset_first_same_as_last(Stepper&, long) {}
inline bool below_minimum_step(double dt, double t, double t0, double t1) {
  const double scale = std::max({std::abs(t), std::abs(t0), std::abs(t1)});
  return !(std::abs(dt) >= 16 * std::numeric_limits<double>::epsilon() * scale);
}
}  // namespace detail

namespace detail {

// Checks the options against the span; returns the number of outputs after t0.
inline long check_integration(const IntegratorOptions& opt, double t0, double t1, double dt_out) {
  const long outputs = std::lround((t1 - t0) / dt_out);
  if (outputs < 1 || std::abs(t0 + outputs * dt_out - t1) > 1e-9 * std::max(1.0, std::abs(t1)))
    throw std::invalid_argument("integrate: (t1 - t0) = " + format(t1 - t0, 10) +
                                " must be a positive multiple of dt_out = " + format(dt_out, 10));
  if (opt.method == Method::rosenbrock4 && !opt.jacobian)
    throw std::invalid_argument(
        "integrate: rosenbrock4 needs the Jacobian of the right-hand side (for a model: the "
        "scene's output forward_dynamics_derivatives)");
  if (!adaptive(opt.method)) {
    if (!(opt.dt > 0) || !std::isfinite(opt.dt))
      throw std::invalid_argument("integrate: dt = " + format(opt.dt) + " must be positive");
    // Past 1e9 steps an output no run ends (and lround would overflow further on).
    if (!(dt_out / opt.dt <= 1e9))
      throw std::invalid_argument(
          "integrate: dt = " + format(opt.dt, 10) + " is " + format(dt_out / opt.dt) +
          " steps for each dt_out = " + format(dt_out, 10) + ": more than any run can take");
    const long per = std::lround(dt_out / opt.dt);
    if (per < 1 || std::abs(per * opt.dt - dt_out) > 1e-9 * dt_out)
      throw std::invalid_argument("integrate: dt_out = " + format(dt_out, 10) +
                                  " must be a multiple of the step dt = " + format(opt.dt, 10));
    return outputs;
  }
  // As ode45 does: a relative tolerance below 100 ulps cannot be met in double precision.
  const double rtol_min = 100 * std::numeric_limits<double>::epsilon();
  if (!(opt.rtol >= rtol_min && opt.rtol <= 0.1))
    throw std::invalid_argument("integrate: rtol = " + format(opt.rtol) + " must be at least " +
                                format(rtol_min) +
                                " (100 x machine epsilon) and at most 0.1 (a relative error of "
                                "10 %)");
  if (!(opt.atol >= 0) || !std::isfinite(opt.atol))
    throw std::invalid_argument("integrate: atol = " + format(opt.atol) + " must be >= 0");
  if (!(opt.breakpoint_interval >= 0) || !std::isfinite(opt.breakpoint_interval) ||
      !std::isfinite(opt.breakpoint_origin))
    throw std::invalid_argument(
        "integrate: breakpoint_interval = " + format(opt.breakpoint_interval) +
        " must be >= 0 (0: none), with a finite origin");
  // A grid that t cannot resolve, or one with more stops than any run can take, would never
  // finish: refuse it up front.
  const double every = opt.breakpoint_interval;
  const double span = std::min(t1, opt.breakpoint_end) - t0;
  if (every > 0 && span > 0 &&
      (below_minimum_step(every, opt.breakpoint_origin, t0, t1) || span / every > 1e9))
    throw std::invalid_argument("integrate: breakpoint_interval = " + format(every) +
                                " (e.g. the torque grid's step) is too small for the time span [" +
                                format(t0) + ", " + format(t1) + "]");
  if (opt.method == Method::dopri5 && every == 0 && opt.step_begin)
    throw std::invalid_argument(
        "integrate: step_begin needs breakpoints with dopri5 (dense output)");
  return outputs;
}

// One integration from t0 to t1: the stepping loops of the methods, and the last accepted
// step (time and state) for the error report, since a failing step leaves x unspecified.
template <class State, class Rhs, class Observer>
class Integration {
 public:
  Integration(const IntegratorOptions& opt, Rhs& rhs, State& x, double t0, double t1, double dt_out,
              long outputs, Observer& observe)
      : t_ok(t0),
        x_ok(x),
        opt_(opt),
        rhs_(rhs),
        x_(x),
        t0_(t0),
        t1_(t1),
        dt_out_(dt_out),
        outputs_(outputs),
        observe_(observe) {}

  double t_ok;
  State x_ok;

  // Fixed steps of opt.dt; step(x, t, dt) advances x.
  template <class Step>
  void fixed_steps(Step&& step) {
    const long per = std::lround(dt_out_ / opt_.dt);
    for (long k = 0; k < outputs_; ++k) {
      for (long s = 0; s < per; ++s) {
        const double t = t0_ + (k * per + s) * opt_.dt;
        if (opt_.step_begin) opt_.step_begin(t, t + opt_.dt);
        step(x_, t, opt_.dt);
        if (opt_.project) opt_.project(x_);
        accept(t0_ + (k * per + s + 1) * opt_.dt, x_);
      }
      observe_(x_, t0_ + (k + 1) * dt_out_);
    }
  }

  // Controlled steps that land on every output time and breakpoint; the step size the
  // controller chose is kept across them (a step shortened to land does not shrink the next).
  template <class Stepper>
  void controlled_steps(Stepper& stepper) {
    double dt = first_step(), t = t0_;
    for (long k = 1; k <= outputs_; ++k) {
      const double t_out = t0_ + k * dt_out_;
      int rejected = 0;
      while (!below_minimum_step(t_out - t, t, t0_, t1_)) {
        const double stop = next_stop(t, t_out), natural = dt;
        // A step that ends on the stop counts as clamped too: the right-hand side may change
        // there (a held torque), so an FSAL method must evaluate its first stage anew.
        const bool clamped = t + dt >= stop;
        const double step = clamped ? stop - t : dt;
        // A stop that rounding puts on t itself would give steps of zero, forever.
        if (below_minimum_step(step, t, t0_, t1_))
          throw integration_error(opt_.method,
                                  "no progress: the next stop at t = " + format(stop) +
                                      " is within rounding of t (breakpoint interval " +
                                      format(opt_.breakpoint_interval) + ")",
                                  t_ok, x_ok);
        if (opt_.step_begin) opt_.step_begin(t, clamped ? stop : t + step);
        dt = step;
        if (stepper.try_step(rhs_, x_, t, dt) == boost::numeric::odeint::success) {
          if (opt_.project) opt_.project(x_);
          if (clamped) {
            t = stop;  // exactly on it, whatever rounding t + step gave
            reset_first_same_as_last(stepper, 0);
          }
          accept(t, x_);
          rejected = 0;
          dt = clamped ? std::max(natural, dt) : dt;
          check_pace(dt, t);
        } else if (++rejected > 500 || below_minimum_step(dt, t, t0_, t1_)) {
          throw step_too_small(dt);
        }
      }
      t = t_out;
      observe_(x_, t_out);
    }
  }

  // Dense output: steps of the controller's own size, states at the outputs by the method's
  // continuous extension.
  template <class Stepper>
  void dense_output_steps(Stepper& stepper) {
    stepper.initialize(x_, t0_, first_step());
    State out = x_;
    for (long k = 1; k <= outputs_; ++k) {
      const double t_out = t0_ + k * dt_out_;
      while (stepper.current_time() < t_out) {
        // No step past t1: its stages would evaluate the right-hand side beyond the span
        // (e.g. past the last torque sample), and the outputs interpolate that step.
        const double left = t1_ - stepper.current_time();
        if (stepper.current_time_step() > left)
          stepper.initialize(State(stepper.current_state()), stepper.current_time(), left);
        stepper.do_step(rhs_);  // odeint throws step_adjustment_error after 500 rejections
        accept(stepper.current_time(), stepper.current_state());
        if (below_minimum_step(stepper.current_time_step(), t_ok, t0_, t1_))
          throw step_too_small(stepper.current_time_step());
        check_pace(stepper.current_time_step(), t_ok);
      }
      stepper.calc_state(t_out, out);
      observe_(out, t_out);
    }
    x_ = out;
  }

 private:
  // The first try: at most a sixteenth of the span, so that one step cannot cover a short span
  // whose error estimate sees nothing (a quintic time law has zero rates at both ends).
  double first_step() const { return std::min({dt_out_, 0.01, (t1_ - t0_) / 16}); }

  // A step size far above the minimum that would still take more than 1e8 steps to reach t1
  // (10 000 such steps in a row): the system is stiff for this method (steep friction, a
  // stiff spring), and the run would take hours without a word.
  void check_pace(double h, double t) {
    if (!((t1_ - t) / std::abs(h) > 1e8)) {
      slow_steps_ = 0;
      return;
    }
    if (++slow_steps_ < 10000) return;
    throw integration_error(
        opt_.method,
        "no practical progress: 10000 steps in a row of about " + format(h) +
            " s, at which reaching t = " + format(t1_) + " would take " + format((t1_ - t) / h) +
            " more; the system is stiff here (steep friction: a small velocity_scale; a stiff "
            "spring)" +
            (opt_.method == Method::rosenbrock4
                 ? std::string()
                 : std::string(": use the integrator rosenbrock4 (the scene must emit "
                               "forward_dynamics_derivatives)")),
        t_ok, x_ok);
  }

  long slow_steps_ = 0;
  const IntegratorOptions& opt_;
  Rhs& rhs_;
  State& x_;
  double t0_, t1_, dt_out_;
  long outputs_;
  Observer& observe_;

  void accept(double t, const State& reached) {
    // A right-hand side that returns inf or NaN instead of throwing must not go on silently.
    if (!reached.allFinite())
      throw integration_error(opt_.method, "state not finite after the step to t = " + format(t),
                              t_ok, x_ok);
    t_ok = t;
    x_ok = reached;
  }
  IntegrationError step_too_small(double dt) const {
    return integration_error(
        opt_.method, "step size " + format(dt) + " below the minimum, tolerance cannot be met",
        t_ok, x_ok);
  }
  // The next output time or breakpoint after t.
  double next_stop(double t, double t_out) const {
    const double every = opt_.breakpoint_interval, origin = opt_.breakpoint_origin;
    if (!(every > 0)) return t_out;
    const double b = origin + std::floor((t - origin) / every + 1 + 1e-9) * every;
    if (b > opt_.breakpoint_end * (1 + 1e-12) + 1e-300) return t_out;  // past the last sample
    return std::min(t_out, b);
  }
};

// Odeint's default_error_checker without its copies: with Eigen states its rel_error takes each
// vector by value (get_unit_value), three allocations per step attempt of dopri5 and rkf78. The
// same expression on references: the same error, to the bit. (Odeint offers no other checker.)
class ErrorChecker {
 public:
  ErrorChecker(double eps_abs, double eps_rel) : eps_abs_(eps_abs), eps_rel_(eps_rel) {}
  // |x_err| / (eps_abs + eps_rel (a_x |x_old| + a_dxdt |dt| |dxdt_old|)) into x_err, a_x = a_dxdt
  // = 1 as odeint's default; returns its largest entry.
  template <class Algebra, class State, class Deriv, class Err, class Time>
  double error(Algebra&, const State& x_old, const Deriv& dxdt_old, Err& x_err, Time dt) const {
    const double a_x = 1, a_dxdt = 1 * std::abs(dt);
    x_err = (x_err.array().abs() /
             (eps_rel_ * (a_x * x_old.array().abs() + a_dxdt * dxdt_old.array().abs()) + eps_abs_))
                .matrix();
    return x_err.template lpNorm<Eigen::Infinity>();
  }

 private:
  double eps_abs_, eps_rel_;
};

// Odeint's rosenbrock4 controller on Eigen states: it takes uBLAS vectors and a pair of the
// right-hand side and the Jacobian, so each step attempt copies the state over and back.
// Odeint's coefficient of df/dt in the fourth stage has the wrong sign (d4 = +0.0362; Hairer
// and Wanner's RODAS has -0.0362): on Prothero-Robinson's stiff test y' = -1e6 (y - sin t) +
// cos t it takes 406,674 steps at tolerance 1e-8 and misses by 8e-6, against 59 steps with
// the sign corrected (measured with Debian's Boost 1.74). So the system is integrated in autonomous
// form, time as the last state (t' = 1) and df/dt as its Jacobian column: the method is invariant
// under that, and the faulty coefficient multiplies zero (56 steps, error 2e-10).
template <class State>
class RosenbrockStepper {
 public:
  using UVector = boost::numeric::ublas::vector<double>;
  using UMatrix = boost::numeric::ublas::matrix<double>;
  RosenbrockStepper(const IntegratorOptions& opt, IntegrationStats& stats)
      : controller_(opt.atol, opt.rtol), jacobian_(opt.jacobian), stats_(stats) {}

  template <class Rhs>
  boost::numeric::odeint::controlled_step_result try_step(Rhs& rhs, State& x, double& t,
                                                          double& dt) {
    const Eigen::Index n = x.size();
    auto to_eigen = [n](const UVector& u) {
      State e(n);
      for (Eigen::Index i = 0; i < n; ++i) e[i] = u[i];
      return e;
    };
    // u = (x, t); du/dt = (f(x, t), 1).
    auto f = [&](const UVector& u, UVector& dudt, double) {
      State d(n);
      rhs(to_eigen(u), d, u[n]);
      for (Eigen::Index i = 0; i < n; ++i) dudt[i] = d[i];
      dudt[n] = 1;
    };
    auto jac = [&](const UVector& u, UMatrix& J, double, UVector& dfdt) {
      ++stats_.jacobian_evaluations;
      Eigen::MatrixXd Je;
      Eigen::VectorXd de;
      jacobian_(Eigen::VectorXd(to_eigen(u)), u[n], Je, de);
      J.clear();
      dfdt.clear();
      for (Eigen::Index i = 0; i < n; ++i) {
        for (Eigen::Index j = 0; j < n; ++j) J(i, j) = Je(i, j);
        J(i, n) = de[i];
      }
    };
    UVector u(n + 1);
    for (Eigen::Index i = 0; i < n; ++i) u[i] = x[i];
    u[n] = t;
    const auto result = controller_.try_step(std::make_pair(f, jac), u, t, dt);
    if (result == boost::numeric::odeint::success) x = to_eigen(u);
    return result;
  }

 private:
  boost::numeric::odeint::rosenbrock4_controller<boost::numeric::odeint::rosenbrock4<double>>
      controller_;
  const std::function<void(const Eigen::VectorXd&, double, Eigen::MatrixXd&, Eigen::VectorXd&)>&
      jacobian_;
  IntegrationStats& stats_;
};

// integrate() for any state type; integrate() below sends run-time-sized states to
// integrate_dynamic.
template <class State, class System, class Observer>
IntegrationStats integrate_states(const IntegratorOptions& opt, System&& f, State& x, double t0,
                                  double t1, double dt_out, Observer&& observe) {
  namespace odeint = boost::numeric::odeint;
  using Algebra = odeint::vector_space_algebra;
  IntegrationStats stats;
  auto rhs = [&](const State& s, State& dsdt, double t) {
    ++stats.rhs_evaluations;
    f(s, dsdt, t);
  };
  const long outputs = detail::check_integration(opt, t0, t1, dt_out);
  observe(x, t0);
  detail::Integration<State, decltype(rhs), std::remove_reference_t<Observer>> run(
      opt, rhs, x, t0, t1, dt_out, outputs, observe);
  try {
    switch (opt.method) {
      case Method::rk4: {
        odeint::runge_kutta4<State, double, State, double, Algebra> stepper;
        run.fixed_steps([&](State& s, double t, double h) { stepper.do_step(rhs, s, t, h); });
        break;
      }
      case Method::dopri5: {
        using Dopri5 = odeint::runge_kutta_dopri5<State, double, State, double, Algebra>;
        using Controlled = odeint::controlled_runge_kutta<Dopri5, detail::ErrorChecker>;
        Controlled controlled(detail::ErrorChecker(opt.atol, opt.rtol));
        if (opt.breakpoint_interval > 0 || opt.project) {
          run.controlled_steps(controlled);
        } else {
          odeint::dense_output_runge_kutta<Controlled> stepper(controlled);
          run.dense_output_steps(stepper);
        }
        break;
      }
      case Method::rkf78: {
        using Rkf78 = odeint::runge_kutta_fehlberg78<State, double, State, double, Algebra>;
        odeint::controlled_runge_kutta<Rkf78, detail::ErrorChecker> stepper(
            detail::ErrorChecker(opt.atol, opt.rtol));
        run.controlled_steps(stepper);
        break;
      }
      case Method::implicit_midpoint:
        run.fixed_steps(
            [&](State& s, double t, double h) { implicit_midpoint_step(rhs, s, t, h); });
        break;
      case Method::rosenbrock4: {
        detail::RosenbrockStepper<State> stepper(opt, stats);
        run.controlled_steps(stepper);
        break;
      }
    }
  } catch (const IntegrationError&) {
    x = run.x_ok;
    throw;
  } catch (const std::runtime_error& e) {  // the right-hand side's or odeint's
    x = run.x_ok;
    throw detail::integration_error(opt.method, e.what(), run.t_ok, run.x_ok);
  } catch (const std::invalid_argument& e) {
    // A model's input check (a quaternion of norm 1e11) on a state the steps made: the run
    // diverged, and what it computed so far is kept like any failed step's. (Other logic
    // errors, such as a library's own consistency check, pass on as they are.)
    x = run.x_ok;
    throw detail::integration_error(
        opt.method, std::string("the state left the model's domain (") + e.what() + ")", run.t_ok,
        run.x_ok);
  }
  return stats;
}

}  // namespace detail

}  // namespace spacearm
