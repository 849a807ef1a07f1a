// The integrator a model needs, from its stiffest linearised mode at the start: the eigenvalue
// of largest magnitude of the state matrix A = [0 I; dqdd/dq dqdd/dqd] (a flexible joint's
// motor mode is about sqrt(k / (p^2 I_m)), friction at rest adds real modes of slope
// (b + Fs/vs) / I_m). RK4 is stable only for |lambda| h below about 2.8; with h |lambda| <= 1
// the mode is resolved (about six steps per period). When that needs a step much smaller than
// the one asked for, an implicit method (rosenbrock4) takes steps the motion needs instead.
#pragma once

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "dynamic_model.hpp"
#include "integrator_options.hpp"

namespace spacearm {

struct StiffestMode {
  double rate = 0;         // |lambda|, 1/s
  double frequency = 0;    // |Im lambda|, rad/s (0: a real, decaying or growing mode)
  std::string coordinate;  // the coordinate with the largest share of the mode
};

namespace detail {
// dqdd/dq (on q's tangent space, nv x nv) and dqdd/dqd: the model's state Jacobian, else central
// differences of forward dynamics (steps of 1e-6 relative, error about 1e-12 of the entries).
inline void state_jacobian(const DynamicModel& m, const Eigen::VectorXd& q,
                           const Eigen::VectorXd& qd, const Eigen::VectorXd& Q, Eigen::MatrixXd& dq,
                           Eigen::MatrixXd& dqd) {
  if (m.has_state_jacobian()) {
    m.forward_dynamics_derivatives(q, qd, Q, dq, dqd);
    return;
  }
  const ConfigurationSpace space = m.configuration_space();
  dq.resize(m.nv, m.nv);
  dqd.resize(m.nv, m.nv);
  for (int i = 0; i < 2 * m.nv; ++i) {
    const bool along_q = i < m.nv;
    const int j = along_q ? i : i - m.nv;
    // The coordinate that moves: past a quaternion's turn (3 tangent entries, 4 in q) by one.
    const int k = space.quaternion_offset;
    const double x = !along_q ? qd[j] : k < 0 || j < k ? q[j] : j < k + 3 ? 0.0 : q[j + 1];
    const double h = 1e-6 * std::max(1.0, std::abs(x));
    auto at = [&](double step) {
      Eigen::VectorXd delta = Eigen::VectorXd::Zero(m.nv), b = qd;
      (along_q ? delta[j] : b[j]) += step;
      return m.forward_dynamics(along_q ? space.integrate(q, delta) : q, b, Q);
    };
    const Eigen::VectorXd column = (at(h) - at(-h)) / (2 * h);
    (along_q ? dq.col(j) : dqd.col(j)) = column;
  }
}
}  // namespace detail

// The stiffest linearised mode of the model at (q, qd) under generalized forces Q.
inline StiffestMode stiffest_mode(const DynamicModel& m, const Eigen::VectorXd& q,
                                  const Eigen::VectorXd& qd, const Eigen::VectorXd& Q) {
  Eigen::MatrixXd dq, dqd;
  detail::state_jacobian(m, q, qd, Q, dq, dqd);
  const Eigen::MatrixXd A = m.configuration_space().motion_jacobian(q, qd, dq, dqd);
  StiffestMode mode;
  if (!A.allFinite()) {
    mode.rate = std::numeric_limits<double>::infinity();
    return mode;
  }
  const Eigen::EigenSolver<Eigen::MatrixXd> eig(A);
  Eigen::Index k = 0;
  eig.eigenvalues().cwiseAbs().maxCoeff(&k);
  mode.rate = std::abs(eig.eigenvalues()[k]);
  mode.frequency = std::abs(eig.eigenvalues()[k].imag());
  Eigen::Index c = 0;
  eig.eigenvectors().col(k).head(m.nq).cwiseAbs().maxCoeff(&c);
  mode.coordinate = m.coordinate_names.at(static_cast<size_t>(c));
  return mode;
}

// What `--integrator auto` runs, and why (one sentence for the user).
struct IntegratorChoice {
  Method method = Method::rk4;
  double dt = 0;  // the fixed step (rk4); 0 for rosenbrock4
  std::string why;
  // The options with this method (and step, for rk4); tolerances and the rest kept.
  void apply(IntegratorOptions& options) const {
    options.method = method;
    if (dt > 0) options.dt = dt;
  }
};

// The mode as words: "3162 rad/s (an oscillation, mostly qm2)".
inline std::string describe(const StiffestMode& mode) {
  char buf[160];
  if (mode.rate == 0) return "0 1/s (none)";
  std::snprintf(buf, sizeof buf, "%.4g 1/s (%s, mostly %s)", mode.rate,
                mode.frequency > 0.1 * mode.rate ? "an oscillation" : "a real mode",
                mode.coordinate.c_str());
  return buf;
}

// RK4 at dt if it resolves the mode (h |lambda| <= 1); RK4 at a step that divides dt_out and
// does, if that is at most 10 times smaller than dt; else rosenbrock4 where the model has its
// state Jacobian, or the small RK4 step with that advice.
inline IntegratorChoice choose_integrator(const StiffestMode& mode, double dt, double dt_out,
                                          bool has_state_jacobian) {
  IntegratorChoice c;
  const double h_max = 1 / mode.rate;  // inf for a model with no dynamics to resolve
  char buf[400];
  if (dt <= h_max) {
    c.dt = dt;
    std::snprintf(buf, sizeof buf,
                  "rk4 at dt = %g s: the stiffest mode at the start, %s, is "
                  "resolved (|lambda| dt = %.2g)",
                  dt, describe(mode).c_str(), mode.rate * dt);
  } else if (h_max >= dt / 10 || !has_state_jacobian) {
    const double steps = std::ceil(dt_out / h_max);
    c.dt = dt_out / steps;
    std::snprintf(buf, sizeof buf,
                  "rk4 at dt = %.3g s (not %g s): the stiffest mode at the start, %s, needs "
                  "|lambda| dt <= 1%s",
                  c.dt, dt, describe(mode).c_str(),
                  has_state_jacobian ? ""
                                     : "; rosenbrock4 could take larger steps (add "
                                       "forward_dynamics_derivatives to the scene's outputs, "
                                       "keeping the others listed)");
  } else {
    c.method = Method::rosenbrock4;
    std::snprintf(buf, sizeof buf,
                  "rosenbrock4: the stiffest mode at the start, %s, would need rk4 steps of "
                  "%.2g s (not %g s)",
                  describe(mode).c_str(), h_max, dt);
  }
  c.why = buf;
  return c;
}

// RK4 at dt is unstable for this mode (|lambda| dt beyond its stability limit, about 2.8).
inline bool unstable_for_rk4(const StiffestMode& mode, double dt) { return mode.rate * dt > 2.5; }

}  // namespace spacearm
