// Simulation: integrates the forward dynamics of a model driven by joint torques and
// records the trajectory with its diagnostics (momentum, energy balance, cond(M)).
#pragma once

#include <functional>
#include <vector>

#include "integrators.hpp"
#include "model.hpp"
#include "torque_signal.hpp"

namespace spacearm {

template <class G>
struct Trajectory {
  using M = Model<G>;
  std::vector<double> t;
  std::vector<typename M::Vector> q, qd;
  std::vector<typename M::Vector3> end_effector, momentum;
  std::vector<double> kinetic_energy;
  std::vector<double> work;  // work done by the joint torques since t0 (trapezoidal in time)
  std::vector<double> condition_number;  // cond(M(q)), 2-norm
  IntegrationStats stats;
};

// Integrates from (q0, qd0) at t = 0 to t_end, sampling every dt_out into traj. tau(t) gives
// the joint (or motor) torques; they enter as generalized forces through
// Model::generalized_forces. On failure it throws IntegrationError (time and state of the
// last accepted step) and traj keeps every sample taken up to then.
template <class G>
void simulate(Trajectory<G>& traj, const Model<G>& model, const typename Model<G>::Vector& q0,
              const typename Model<G>::Vector& qd0,
              const std::function<typename Model<G>::JointVector(double)>& tau, double t_end, double dt_out,
              const IntegratorOptions& options) {
  using M = Model<G>;
  constexpr int n = M::kNq;
  using State = Eigen::Matrix<double, 2 * n, 1>;
  State x;
  x << q0, qd0;
  traj = Trajectory<G>();
  auto f = [&](const State& s, State& dsdt, double t) {
    const typename M::Vector q = s.template head<n>(), qd = s.template tail<n>();
    dsdt.template head<n>() = qd;
    try {
      dsdt.template tail<n>() = model.forward_dynamics(q, qd, model.generalized_forces(tau(t)));
    } catch (const DynamicsError& e) {
      throw DynamicsError(std::string(e.what()) + " at t = " + std::to_string(t));
    }
  };
  double power_prev = 0;
  auto observe = [&](const State& s, double t) {
    const typename M::Vector q = s.template head<n>(), qd = s.template tail<n>();
    traj.t.push_back(t);
    traj.q.push_back(q);
    traj.qd.push_back(qd);
    traj.end_effector.push_back(model.end_effector_pose(q));
    if constexpr (G::kHas_momentum) traj.momentum.push_back(model.momentum(q, qd));
    traj.kinetic_energy.push_back(model.kinetic_energy(q, qd));
    traj.condition_number.push_back(model.condition_number(q));
    const double power = model.generalized_forces(tau(t)).dot(qd);
    traj.work.push_back(traj.work.empty() ? 0.0 : traj.work.back() + 0.5 * (power + power_prev) * (t - traj.t[traj.t.size() - 2]));
    power_prev = power;
  };
  traj.stats = integrate(options, f, x, 0.0, t_end, dt_out, observe);
}

// Replays sampled torques: adaptive steps land on every sample up to the last one (a kink
// or a jump of the signal there), and with Interpolation::hold every stage of a step sees
// the one sample of the interval the step lies in (a true zero-order hold). The fixed-step
// methods then need the samples' interval to be a multiple of options.dt.
template <class G, int N>
void simulate(Trajectory<G>& traj, const Model<G>& model, const typename Model<G>::Vector& q0,
              const typename Model<G>::Vector& qd0, const TorqueSignal<N>& tau, double t_end, double dt_out,
              IntegratorOptions options) {
  using Joint = typename Model<G>::JointVector;
  const bool hold = tau.mode() == Interpolation::hold;
  const bool fixed = options.method == Method::rk4 || options.method == Method::implicit_midpoint;
  auto multiple = [](double a, double b) { return std::abs(a / b - std::round(a / b)) <= 1e-9 * std::max(1.0, a / b); };
  if (hold && fixed && !(multiple(tau.dt(), options.dt) && multiple(tau.t_first(), options.dt)))
    throw std::invalid_argument("simulate: a held torque with fixed steps needs the samples' interval (" +
                                detail::format(tau.dt()) + " s) and first time to be multiples of the step dt (" +
                                detail::format(options.dt) + " s), so that no step straddles a sample");
  options.breakpoint_interval = tau.dt();
  options.breakpoint_origin = tau.t_first();
  options.breakpoint_end = tau.t_last();
  double step_a = 0, step_b = -1;
  options.step_begin = [&](double a, double b) {
    step_a = a;
    step_b = b;
  };
  // Inside a step: the step's sample (hold) or the value at t; at an output time: tau(t).
  const std::function<Joint(double)> torque = [&](double t) -> Joint {
    if (hold && t >= step_a && t <= step_b) return tau.held_over(step_a, step_b);
    return tau(t);
  };
  simulate(traj, model, q0, qd0, torque, t_end, dt_out, options);
}

template <class G, class Torque>
Trajectory<G> simulate(const Model<G>& model, const typename Model<G>::Vector& q0,
                       const typename Model<G>::Vector& qd0,
                       const Torque& tau, double t_end, double dt_out, const IntegratorOptions& options) {
  Trajectory<G> traj;
  simulate(traj, model, q0, qd0, tau, t_end, dt_out, options);  // a TorqueSignal or a function of t
  return traj;
}

}  // namespace spacearm
