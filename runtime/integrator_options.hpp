// The integrators' options and what they report (integrators.hpp integrates): the methods by
// name, IntegratorOptions, IntegrationStats and IntegrationError. No Boost.
#pragma once

#include <Eigen/Core>

#include <functional>
#include <limits>
#include <stdexcept>
#include <string>

namespace spacearm {

enum class Method { rk4, dopri5, rkf78, implicit_midpoint, rosenbrock4 };

inline Method method_from_string(const std::string& name) {
  if (name == "rk4") return Method::rk4;
  if (name == "dopri5") return Method::dopri5;
  if (name == "rkf78") return Method::rkf78;
  if (name == "implicit_midpoint") return Method::implicit_midpoint;
  if (name == "rosenbrock4") return Method::rosenbrock4;
  throw std::invalid_argument("unknown integrator '" + name +
                              "' (known: rk4, dopri5, rkf78, implicit_midpoint, rosenbrock4)");
}
inline std::string to_string(Method m) {
  switch (m) {
    case Method::rk4:
      return "rk4";
    case Method::dopri5:
      return "dopri5";
    case Method::rkf78:
      return "rkf78";
    case Method::implicit_midpoint:
      return "implicit_midpoint";
    case Method::rosenbrock4:
      return "rosenbrock4";
  }
  return "?";
}
// The methods that choose their own steps (rtol, atol) rather than taking dt.
inline bool adaptive(Method m) {
  return m == Method::dopri5 || m == Method::rkf78 || m == Method::rosenbrock4;
}

struct IntegratorOptions {
  Method method = Method::rk4;
  double dt = 0.01;    // step of the fixed-step methods
  double rtol = 1e-8;  // tolerances of the adaptive methods
  double atol = 1e-10;
  // > 0: the adaptive methods also land on t0 + k * breakpoint_interval, so that no step
  // straddles a point where the right-hand side has a kink (e.g. torque samples joined by
  // straight lines): a step across one loses the method's order.
  double breakpoint_interval = 0;
  // The breakpoints are breakpoint_origin + k * breakpoint_interval, up to breakpoint_end
  // (e.g. the first and last torque samples); none after it.
  double breakpoint_origin = 0;
  double breakpoint_end = std::numeric_limits<double>::infinity();
  // Called before every step attempt with the step's start and end times, so that a
  // zero-order hold can give every stage of the step one sample (TorqueSignal::held_over).
  // Not available for dopri5 without breakpoints (dense output chooses its steps itself).
  std::function<void(double t_begin, double t_end)> step_begin;
  // For rosenbrock4: the Jacobian J = df/dx of the right-hand side and df/dt, at (x, t).
  std::function<void(const Eigen::VectorXd& x, double t, Eigen::MatrixXd& J, Eigen::VectorXd& dfdt)>
      jacobian;
  // Where the state lives on a manifold (a unit quaternion): moves x back onto it after every
  // accepted step. dopri5 then takes controlled steps (its dense output would interpolate off
  // the manifold between steps).
  std::function<void(Eigen::Ref<Eigen::VectorXd> x)> project;
};

struct IntegrationStats {
  long rhs_evaluations = 0;
  long jacobian_evaluations = 0;  // rosenbrock4: one per step attempt
};

// An integration that cannot go on (the right-hand side failed, or an adaptive method cannot
// meet its tolerance). Carries the last accepted time and state; everything observed up to
// then has already been passed to the observer.
class IntegrationError : public std::runtime_error {
 public:
  IntegrationError(const std::string& what, double t, Eigen::VectorXd state)
      : std::runtime_error(what), t_(t), state_(std::move(state)) {}
  double t() const { return t_; }
  const Eigen::VectorXd& state() const { return state_; }

 private:
  double t_;
  Eigen::VectorXd state_;
};

}  // namespace spacearm
