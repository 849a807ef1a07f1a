// The Jacobians of one RK4 step of the motion, the form iLQR/DDP and MPC solvers take: x+ =
// step(x, tau) over dt with the joint torques tau held through the step, x = (q, v) on the
// tangent space (q ⊕ delta, configuration_space.hpp; the convention of MuJoCo's
// mjd_transitionFD), A = dx+/dx (2 nv x 2 nv) and B = dx+/dtau (2 nv x N, link-side torques).
// The step is the runtime's rk4 (integrators.hpp: Odeint's classic stages on (q, v) with dq/dt =
// G(q) v, the quaternion projected after the step), differentiated stage by stage with the
// model's exact state Jacobian (forward_dynamics_derivatives; central differences where the
// scene lacks it), so A and B are exact but for rounding.
#pragma once

#include <Eigen/Dense>

#include <stdexcept>
#include <string>

#include "configuration_space.hpp"
#include "dynamic_model.hpp"
#include "integrator_choice.hpp"

namespace spacearm {

struct StepJacobians {
  Eigen::VectorXd q, v;  // the state after the step (the quaternion projected)
  Eigen::MatrixXd A, B;  // d(q+, v+)/d(q, v) and d(q+, v+)/dtau, on the tangent spaces
};

namespace detail {

// One stage of the step at x = (q, v): the right-hand side f = (dq/dt, qdd) and its Jacobians in
// q's coordinates, J = df/dx (nq + nv square) and T = df/dtau (nq + nv by N).
struct StageDerivatives {
  Eigen::VectorXd f;
  Eigen::MatrixXd J, T;
  int nq = 0, nv = 0, quaternion_offset = -1;
  // J X at half the work of a dense product: the rate's rows [d(dq/dt)/dq, G] are zero and the
  // identity but for the quaternion's 4 rows, so only the dynamics' rows are multiplied out.
  Eigen::MatrixXd times(const Eigen::MatrixXd& X) const {
    const int k = quaternion_offset;
    const auto Xq = X.topRows(nq), Xv = X.bottomRows(nv);
    Eigen::MatrixXd out(nq + nv, X.cols());
    if (k < 0) {
      out.topRows(nq) = Xv;
    } else {
      out.topRows(k) = Xv.topRows(k);
      out.middleRows(k, 4) = J.block(k, k, 4, 4) * Xq.middleRows(k, 4) +
                             J.block(k, nq + k, 4, 3) * Xv.middleRows(k, 3);
      out.middleRows(k + 4, nq - k - 4) = Xv.bottomRows(nv - k - 3);
    }
    out.bottomRows(nv).noalias() = J.bottomRows(nv) * X;
    return out;
  }
};
inline StageDerivatives stage_derivatives(const DynamicModel& m, const Eigen::VectorXd& x,
                                          const Eigen::VectorXd& Q) {
  const ConfigurationSpace space = m.configuration_space();
  const int nq = m.nq, nv = m.nv, N = m.num_links;
  const Eigen::VectorXd q = x.head(nq), v = x.tail(nv);
  StageDerivatives s;
  s.nq = nq, s.nv = nv, s.quaternion_offset = space.quaternion_offset;
  Eigen::VectorXd qdd;
  Eigen::MatrixXd dq, dqd, dtau;
  s.T = Eigen::MatrixXd::Zero(nq + nv, N);
  if (m.state_and_torque_jacobian) {  // qdd from the same call
    qdd = m.state_and_torque_jacobian(q, v, Q, dq, dqd, dtau);
    s.T.bottomRows(nv) = dtau;
  } else {
    // The Jacobian by differences; qdd is affine in Q, so each joint's column is the difference
    // of two solves, exact but for rounding.
    qdd = m.forward_dynamics(q, v, Q);
    state_jacobian(m, q, v, Q, dq, dqd);
    for (int j = 0; j < N; ++j)
      s.T.col(j).tail(nv) =
          m.forward_dynamics(q, v, Q + m.generalized_forces(Eigen::VectorXd::Unit(N, j))) - qdd;
  }
  s.f.resize(nq + nv);
  s.f << space.rate(q, v), qdd;
  s.J = space.motion_jacobian(q, v, dq, dqd);
  return s;
}

}  // namespace detail

// One rk4 step of dt from x = (q, v) in q's coordinates, before the quaternion's projection,
// under link-side torques linear in time from tau_start to tau_end over the step (as a replay
// interpolates a plan's samples), with its Jacobians there: X = dx+/dx ((nq + nv) square) and
// U_start, U_end = dx+/dtau_start, dx+/dtau_end. A direct multiple-shooting planner takes these
// (optimal_plan.cpp): exact in coordinates, as the dynamics see the quaternion only normalized.
struct CoordinateStep {
  Eigen::VectorXd x;
  Eigen::MatrixXd X, U_start, U_end;
};
inline CoordinateStep rk4_step_in_coordinates(const DynamicModel& m, const Eigen::VectorXd& x,
                                              const Eigen::VectorXd& tau_start,
                                              const Eigen::VectorXd& tau_end, double dt) {
  const int n = m.nq + m.nv, N = m.num_links;
  // The classic stages, k_i = f(x + c_i dt k_{i-1}, tau(c_i)), each with dk_i/dx (D) and
  // dk_i/dtau_start, dk_i/dtau_end (Ea, Eb).
  const double c[] = {0, dt / 2, dt / 2, dt}, w[] = {1, 2, 2, 1};
  Eigen::VectorXd k = Eigen::VectorXd::Zero(n), sum = Eigen::VectorXd::Zero(n);
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(n, n), Ea = Eigen::MatrixXd::Zero(n, N), Eb = Ea;
  Eigen::MatrixXd D_sum = D, Ea_sum = Ea, Eb_sum = Eb;
  for (int i = 0; i < 4; ++i) {
    const double along = c[i] / dt;  // the stage's place in the step: its torque's weights
    const Eigen::VectorXd Q = m.generalized_forces((1 - along) * tau_start + along * tau_end);
    const detail::StageDerivatives s = detail::stage_derivatives(m, x + c[i] * k, Q);
    D = s.J + c[i] * s.times(D);
    Ea = c[i] * s.times(Ea) + (1 - along) * s.T;
    Eb = c[i] * s.times(Eb) + along * s.T;
    k = s.f;
    sum += w[i] * k, D_sum += w[i] * D, Ea_sum += w[i] * Ea, Eb_sum += w[i] * Eb;
  }
  CoordinateStep r;
  r.x = x + dt / 6 * sum;
  r.X = Eigen::MatrixXd::Identity(n, n) + dt / 6 * D_sum;
  r.U_start = dt / 6 * Ea_sum;
  r.U_end = dt / 6 * Eb_sum;
  return r;
}

// The same step's end alone, without its Jacobians (a line search's trial points).
inline Eigen::VectorXd rk4_step_end(const DynamicModel& m, const Eigen::VectorXd& x,
                                    const Eigen::VectorXd& tau_start,
                                    const Eigen::VectorXd& tau_end, double dt) {
  const ConfigurationSpace space = m.configuration_space();
  const int nq = m.nq, nv = m.nv;
  const double c[] = {0, dt / 2, dt / 2, dt}, w[] = {1, 2, 2, 1};
  Eigen::VectorXd k = Eigen::VectorXd::Zero(nq + nv), sum = k, s(nq + nv);
  for (int i = 0; i < 4; ++i) {
    const double along = c[i] / dt;
    const Eigen::VectorXd Q = m.generalized_forces((1 - along) * tau_start + along * tau_end);
    s = x + c[i] * k;
    // Each part on its own (a comma initializer of the two calls failed Eigen's size assertion
    // in the sanitizers' -O1 build, though both sizes were right).
    k.head(nq) = space.rate(s.head(nq), s.tail(nv));
    k.tail(nv) = m.forward_dynamics(s.head(nq), s.tail(nv), Q);
    sum += w[i] * k;
  }
  return x + dt / 6 * sum;
}

// A and B of one rk4 step of dt from (q, v) under the link-side joint torques tau.
inline StepJacobians rk4_step_jacobians(const DynamicModel& m, const Eigen::VectorXd& q,
                                        const Eigen::VectorXd& v, const Eigen::VectorXd& tau,
                                        double dt) {
  const int nq = m.nq, nv = m.nv, n = nq + nv;
  if (q.size() != nq || v.size() != nv || tau.size() != m.num_links)
    throw std::invalid_argument("step Jacobians of model " + m.name + ": q, v and tau need " +
                                std::to_string(nq) + ", " + std::to_string(nv) + " and " +
                                std::to_string(m.num_links) + " values");
  if (!(dt > 0) || !std::isfinite(dt))
    throw std::invalid_argument("step Jacobians of model " + m.name +
                                ": dt must be positive and finite, got " + std::to_string(dt));
  const ConfigurationSpace space = m.configuration_space();
  Eigen::VectorXd x(n);
  x << q, v;
  const CoordinateStep step = rk4_step_in_coordinates(m, x, tau, tau, dt);
  // Into the tangent spaces: dq = G(q) delta at the start, delta+ = W(q+) dq+ at the end (the
  // projection's own derivative is radial, which W ignores).
  Eigen::MatrixXd by_q, G;
  space.rate_jacobians(q, v, by_q, G);
  Eigen::MatrixXd into = Eigen::MatrixXd::Zero(n, 2 * nv), out = Eigen::MatrixXd::Zero(2 * nv, n);
  into.topLeftCorner(nq, nv) = G;
  into.bottomRightCorner(nv, nv).setIdentity();
  out.topLeftCorner(nv, nq) = space.tangent_map(step.x.head(nq));
  out.bottomRightCorner(nv, nv).setIdentity();
  StepJacobians r;
  r.A = out * step.X * into;
  r.B = out * (step.U_start + step.U_end);
  r.q = step.x.head(nq);
  space.project(r.q);
  r.v = step.x.tail(nv);
  return r;
}

}  // namespace spacearm
