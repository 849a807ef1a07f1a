// Simulation: integrates the forward dynamics of a model driven by joint torques and
// records the trajectory with its diagnostics (momentum, energy balance, cond(M)).
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "dynamic_model.hpp"
#include "integrators.hpp"
#include "model.hpp"
#include "torque_signal.hpp"

namespace spacearm {

template <class G>
struct Trajectory {
  using M = Model<G>;
  std::vector<double> t;
  std::vector<typename M::Vector> q;
  std::vector<typename M::Velocity> qd;
  std::vector<typename M::Pose> end_effector;
  std::vector<typename M::Momentum> momentum;
  std::vector<double> kinetic_energy;
  std::vector<double> work;  // work done by the joint torques since t0 (trapezoidal in time)
  std::vector<double> condition_number;  // cond(M(q)), 2-norm
  IntegrationStats stats;
};

// The state (q, qd) of a model as one vector for the integrators: fixed size for a Model<G>,
// dynamic for a DynamicModel.
template <class Mdl>
using MotionState =
    Eigen::Matrix<double,
                  Mdl::Vector::RowsAtCompileTime == Eigen::Dynamic ||
                          Mdl::Velocity::RowsAtCompileTime == Eigen::Dynamic
                      ? Eigen::Dynamic
                      : Mdl::Vector::RowsAtCompileTime + Mdl::Velocity::RowsAtCompileTime,
                  1>;

namespace detail {
// dQ/dt, the slope of the generalized forces of the torque tau at t (whose value there is Q),
// by a one-sided difference: exact on a piecewise-linear signal's segment. The right slope,
// or the left one where the torque ends at t.
template <class Mdl, class Torque>
typename Mdl::Velocity force_slope(const Mdl& model, const Torque& tau, double t,
                                   const typename Mdl::Velocity& Q) {
  const double h = 1e-6 * std::max(1.0, std::abs(t));
  try {
    return (model.generalized_forces(tau(t + h)) - Q) / h;
  } catch (const std::exception&) {
    return (Q - model.generalized_forces(tau(t - h))) / h;
  }
}

// The Jacobian of the motion's right-hand side f(q, qd, t) = (qd, qdd(q, qd, Q(t))) for
// rosenbrock4: [[d(dq/dt)/dq, d(dq/dt)/dqd], [dqdd/dq, dqdd/dqd]] (the first row [0, I] without a
// quaternion, configuration_space.hpp) from the model's exact state Jacobian, and
// df/dt = (0, M^-1 dQ/dt), which is qdd(Q + dQ/dt) - qdd(Q) since qdd is affine in Q.
template <class Mdl, class Torque>
auto motion_jacobian(const Mdl& model, const Torque& tau, Eigen::Index nq, Eigen::Index nv, int)
    -> decltype(model.forward_dynamics_derivatives(std::declval<typename Mdl::Vector>(),
                                                   std::declval<typename Mdl::Velocity>(),
                                                   std::declval<typename Mdl::Velocity>(),
                                                   std::declval<typename Mdl::TangentJacobian&>(),
                                                   std::declval<typename Mdl::Matrix&>()),
                decltype(IntegratorOptions::jacobian)()) {
  return [&model, &tau, nq, nv](const Eigen::VectorXd& x, double t, Eigen::MatrixXd& J,
                                Eigen::VectorXd& dfdt) {
    const typename Mdl::Vector q = x.head(nq);
    const typename Mdl::Velocity qd = x.tail(nv);
    const typename Mdl::Velocity Q = model.generalized_forces(tau(t));
    typename Mdl::TangentJacobian dq;
    typename Mdl::Matrix dqd;
    const typename Mdl::Velocity qdd = model.forward_dynamics_derivatives(q, qd, Q, dq, dqd);
    J = model.configuration_space().motion_jacobian(q, qd, dq, dqd);
    dfdt = Eigen::VectorXd::Zero(nq + nv);
    const typename Mdl::Velocity dQ = force_slope(model, tau, t, Q);
    if (!dQ.isZero(0)) dfdt.tail(nv) = model.forward_dynamics(q, qd, Q + dQ) - qdd;
  };
}
template <class Mdl, class Torque>
decltype(IntegratorOptions::jacobian) motion_jacobian(const Mdl&, const Torque&, Eigen::Index,
                                                      Eigen::Index, long) {
  return {};  // the model has no state Jacobian: integrate() refuses rosenbrock4
}

// The torques at t into tau: by the signal's evaluate(t, tau) where it has one (TorqueSignal,
// TorqueReplay: nothing allocated), else by its value.
template <class Torque, class Joint>
auto torque_into(const Torque& signal, double t, Joint& tau, int)
    -> decltype(signal.evaluate(t, tau), void()) {
  signal.evaluate(t, tau);
}
template <class Torque, class Joint>
void torque_into(const Torque& signal, double t, Joint& tau, long) {
  tau = signal(t);
}

// qdd = model.forward_dynamics(q, qd, Q) into qdd, allocating nothing: a linked Model<G> at
// fixed size; a DynamicModel through a call on a workspace of its own where its source makes
// one (dynamic_model.hpp), else through its forward_dynamics.
template <class G>
auto forward_dynamics_call(const Model<G>& model) {
  return [&model](const auto& q, const auto& qd, const auto& Q, auto& qdd) {
    qdd = model.forward_dynamics(q, qd, Q);
  };
}
inline auto forward_dynamics_call(const DynamicModel& model) {
  DynamicModel::ForwardDynamicsCall call;
  if (model.make_forward_dynamics_call) call = model.make_forward_dynamics_call();
  return [&model, call](const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                        const Eigen::VectorXd& Q, Eigen::VectorXd& qdd) {
    if (call)
      call(q.data(), qd.data(), Q.data(), qdd.data());
    else
      qdd = model.forward_dynamics(q, qd, Q);
  };
}

template <class G>
Eigen::Index num_links_of(const Model<G>&) {
  return Model<G>::kNumLinks;
}
inline Eigen::Index num_links_of(const DynamicModel& model) { return model.num_links; }

// integrate_motion's right-hand side f(q, qd, t) = (dq/dt, qdd(q, qd, Q(t))) on workspaces
// sized once: nothing is allocated per evaluation.
template <class Mdl, class Torque>
class MotionRhs {
 public:
  MotionRhs(const Mdl& model, const Torque& tau, Eigen::Index nq, Eigen::Index nv)
      : model_(model),
        tau_(tau),
        space_(model.configuration_space()),
        fd_(forward_dynamics_call(model)),
        q_(nq),
        qd_(nv),
        Q_(nv),
        qdd_(nv),
        joint_(num_links_of(model)) {}
  template <class State>
  void operator()(const State& s, State& dsdt, double t) {
    const Eigen::Index nq = q_.size(), nv = qd_.size();
    q_ = s.head(nq);
    qd_ = s.tail(nv);
    dsdt.resize(nq + nv);  // a no-op at fixed size
    space_.rate(q_, qd_, dsdt.head(nq));
    torque_into(tau_, t, joint_, 0);
    model_.generalized_forces(joint_, Q_);
    try {
      fd_(q_, qd_, Q_, qdd_);
    } catch (const DynamicsError& e) {
      throw DynamicsError(std::string(e.what()) + " at t = " + number_text(t));
    }
    dsdt.tail(nv) = qdd_;
  }

 private:
  const Mdl& model_;
  const Torque& tau_;
  ConfigurationSpace space_;
  decltype(forward_dynamics_call(std::declval<const Mdl&>())) fd_;
  typename Mdl::Vector q_;
  typename Mdl::Velocity qd_, Q_, qdd_;
  typename Mdl::JointVector joint_;
};
}  // namespace detail

// Integrates the forward dynamics of any runtime model, a linked Model<G> or a DynamicModel
// (dynamic_model.hpp), from (q0, qd0) at t = 0 to t_end under the joint (or motor) torques
// tau(t), and calls observe(t, q, qd) every dt_out. The torques enter as generalized forces
// (Model::generalized_forces, eq. 14); a failure of the dynamics names its time. Both
// simulate() below and the CLI's simulate run on it.
template <class Mdl, class Torque, class Observer>
IntegrationStats integrate_motion(const Mdl& model, const typename Mdl::Vector& q0,
                                  const typename Mdl::Velocity& qd0, const Torque& tau,
                                  double t_end, double dt_out, const IntegratorOptions& options,
                                  Observer&& observe) {
  using State = MotionState<Mdl>;
  using Vector = typename Mdl::Vector;
  using Velocity = typename Mdl::Velocity;
  const Eigen::Index nq = q0.size(), nv = qd0.size();
  State x(nq + nv);
  x << q0, qd0;
  detail::MotionRhs<Mdl, Torque> f(model, tau, nq, nv);
  Vector q(nq);
  Velocity qd(nv);
  auto on_sample = [&](const State& s, double t) {
    q = s.head(nq);
    qd = s.tail(nv);
    observe(t, q, qd);
  };
  IntegratorOptions opt = options;
  const ConfigurationSpace space = model.configuration_space();
  if (space.quaternion_offset >= 0 && !opt.project)
    opt.project = [space, nq](Eigen::Ref<Eigen::VectorXd> s) {
      auto q = s.head(nq);
      space.project(q);
    };
  if (opt.project) opt.project(x);  // the start on the manifold too (its first sample is output)
  if (opt.method == Method::rosenbrock4 && !opt.jacobian && model.has_state_jacobian())
    opt.jacobian = detail::motion_jacobian(model, tau, nq, nv, 0);
  return integrate(opt, f, x, 0.0, t_end, dt_out, on_sample);
}

// Integrates from (q0, qd0) at t = 0 to t_end, sampling every dt_out into traj. tau(t) gives
// the joint (or motor) torques (integrate_motion). On failure it throws IntegrationError (time
// and state of the last accepted step) and traj keeps every sample taken up to then.
template <class G>
void simulate(Trajectory<G>& traj, const Model<G>& model, const typename Model<G>::Vector& q0,
              const typename Model<G>::Velocity& qd0,
              const std::function<typename Model<G>::JointVector(double)>& tau, double t_end,
              double dt_out, const IntegratorOptions& options) {
  using M = Model<G>;
  traj = Trajectory<G>();
  double power_prev = 0;
  auto record = [&](double t, const typename M::Vector& q, const typename M::Velocity& qd) {
    traj.t.push_back(t);
    traj.q.push_back(q);
    traj.qd.push_back(qd);
    traj.end_effector.push_back(model.end_effector_pose(q));
    if constexpr (G::kHas_momentum) traj.momentum.push_back(model.momentum(q, qd));
    traj.kinetic_energy.push_back(model.kinetic_energy(q, qd));
    traj.condition_number.push_back(model.condition_number(q));
    const double power = model.generalized_forces(tau(t)).dot(qd);
    traj.work.push_back(traj.work.empty() ? 0.0
                                          : traj.work.back() + 0.5 * (power + power_prev) *
                                                                   (t - traj.t[traj.t.size() - 2]));
    power_prev = power;
  };
  traj.stats = integrate_motion(model, q0, qd0, tau, t_end, dt_out, options, record);
}

// Sampled torques replayed by an integrator: adaptive steps land on every sample up to the
// last one (a kink or a jump of the signal there), and with Interpolation::hold every stage
// of a step sees the one sample of the interval the step lies in (a true zero-order hold).
// The fixed-step methods then need the samples' interval and first time to be multiples of
// the step, else std::invalid_argument naming `step_name` (e.g. "--dt"). Sets the options'
// breakpoints and step_begin; keep the object alive (it is not copied) while integrating.
template <int N>
class TorqueReplay {
 public:
  using Joint = typename TorqueSignal<N>::Joint;
  TorqueReplay(const TorqueSignal<N>& tau, IntegratorOptions& options, const std::string& step_name)
      : tau_(tau), hold_(tau.mode() == Interpolation::hold) {
    const bool fixed = !adaptive(options.method);
    auto multiple = [](double x, double of) {
      return std::abs(x / of - std::round(x / of)) <= 1e-9 * std::max(1.0, x / of);
    };
    if (hold_ && fixed && !(multiple(tau.dt(), options.dt) && multiple(tau.t_first(), options.dt)))
      throw std::invalid_argument(
          "a held torque with " + to_string(options.method) +
          " needs the torque samples' interval (" + number_text(tau.dt()) +
          " s) to be a multiple of " + step_name + " (" + number_text(options.dt) +
          " s), and their first time too, so that no step straddles a sample");
    options.breakpoint_interval = tau.dt();
    options.breakpoint_origin = tau.t_first();
    options.breakpoint_end = tau.t_last();
    options.step_begin = [this](double a, double b) {
      step_a_ = a;
      step_b_ = b;
    };
  }
  TorqueReplay(const TorqueReplay&) = delete;
  TorqueReplay& operator=(const TorqueReplay&) = delete;

  // Inside a step: the step's sample (hold) or the value at t; at an output time: tau(t).
  Joint operator()(double t) const {
    Joint value = Joint::Zero(tau_.size());
    evaluate(t, value);
    return value;
  }
  // The same into `value` (a joint vector): no allocation.
  template <class Out>
  void evaluate(double t, Out& value) const {
    // held_over(a, b) is the value at the step's midpoint.
    tau_.evaluate(hold_ && t >= step_a_ && t <= step_b_ ? 0.5 * (step_a_ + step_b_) : t, value);
  }

 private:
  const TorqueSignal<N>& tau_;
  bool hold_;
  double step_a_ = 0, step_b_ = -1;
};

// Replays sampled torques (see TorqueReplay).
template <class G, int N>
void simulate(Trajectory<G>& traj, const Model<G>& model, const typename Model<G>::Vector& q0,
              const typename Model<G>::Velocity& qd0, const TorqueSignal<N>& tau, double t_end,
              double dt_out, IntegratorOptions options) {
  const TorqueReplay<N> replay(tau, options, "the step dt");
  const std::function<typename Model<G>::JointVector(double)> torque = [&](double t) {
    return replay(t);
  };
  simulate(traj, model, q0, qd0, torque, t_end, dt_out, options);
}

template <class G, class Torque>
Trajectory<G> simulate(const Model<G>& model, const typename Model<G>::Vector& q0,
                       const typename Model<G>::Velocity& qd0, const Torque& tau, double t_end,
                       double dt_out, const IntegratorOptions& options) {
  Trajectory<G> traj;
  simulate(traj, model, q0, qd0, tau, t_end, dt_out, options);  // a TorqueSignal or a function of t
  return traj;
}

}  // namespace spacearm
