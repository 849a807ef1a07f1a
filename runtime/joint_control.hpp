// Closed-loop joint control of the free-floating arm (the paper's future work: "analysis of
// motor driving torques in the closed-loop system for the manipulator equipped with gears").
// Two controllers, both giving link-side joint torques tau (the motor gets tau / p, eq. 14):
//   PdController              tau = Kp e + Kd de, on the link-side joint errors;
//   ComputedTorqueController  tau from the inverse dynamics of a chosen control model (the
//                             reference, a rigid geared or a flexible one) with the base free
//                             (no force on it), for the joint accelerations qdd_d + Kd de + Kp e.
// The plant may be another model than the controller's. The controller is sampled: it reads
// the plant's state every `period` and holds its torque until the next sample (zero-order
// hold), as a digital joint controller does; integrate_closed_loop runs the loop.
#pragma once

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "dynamic_model.hpp"
#include "simulation.hpp"

namespace spacearm {

// The desired link-side joint motion at one time.
struct JointTarget {
  Eigen::VectorXd q, qd, qdd;
};

// A joint trajectory through samples of (q, qd, qdd) on a uniform grid (e.g. a plan's), by the
// quintic Hermite polynomial of each interval: q, qd and qdd are continuous and consistent.
class SampledJointTrajectory {
 public:
  SampledJointTrajectory(double t0, double dt, std::vector<Eigen::VectorXd> q,
                         std::vector<Eigen::VectorXd> qd, std::vector<Eigen::VectorXd> qdd)
      : t0_(t0), dt_(dt), q_(std::move(q)), qd_(std::move(qd)), qdd_(std::move(qdd)) {
    if (!(dt_ > 0) || q_.size() < 2 || qd_.size() != q_.size() || qdd_.size() != q_.size())
      throw std::invalid_argument(
          "SampledJointTrajectory: needs dt > 0 and at least two "
          "samples of q, qd and qdd each");
    for (size_t k = 0; k < q_.size(); ++k)
      if (q_[k].size() != q_[0].size() || qd_[k].size() != q_[0].size() ||
          qdd_[k].size() != q_[0].size())
        throw std::invalid_argument("SampledJointTrajectory: sample " + std::to_string(k) +
                                    " has another joint count than sample 0");
  }
  // Outside the samples: at rest at the first or last one (meant for a plan from rest to
  // rest; otherwise the rates jump there).
  JointTarget operator()(double t) const {
    const double s = std::clamp((t - t0_) / dt_, 0.0, static_cast<double>(q_.size() - 1));
    const size_t k = std::min(static_cast<size_t>(s), q_.size() - 2);
    const double u = s - k, h = dt_;
    // Quintic Hermite basis on [0, 1] and its derivatives (d/dt = d/du / h).
    const double u2 = u * u, u3 = u2 * u, u4 = u3 * u, u5 = u4 * u;
    const double H[6] = {1 - 10 * u3 + 15 * u4 - 6 * u5,    u - 6 * u3 + 8 * u4 - 3 * u5,
                         0.5 * (u2 - 3 * u3 + 3 * u4 - u5), 10 * u3 - 15 * u4 + 6 * u5,
                         -4 * u3 + 7 * u4 - 3 * u5,         0.5 * (u3 - 2 * u4 + u5)};
    const double dH[6] = {-30 * u2 + 60 * u3 - 30 * u4,
                          1 - 18 * u2 + 32 * u3 - 15 * u4,
                          0.5 * (2 * u - 9 * u2 + 12 * u3 - 5 * u4),
                          30 * u2 - 60 * u3 + 30 * u4,
                          -12 * u2 + 28 * u3 - 15 * u4,
                          0.5 * (3 * u2 - 8 * u3 + 5 * u4)};
    const double ddH[6] = {-60 * u + 180 * u2 - 120 * u3,
                           -36 * u + 96 * u2 - 60 * u3,
                           0.5 * (2 - 18 * u + 36 * u2 - 20 * u3),
                           60 * u - 180 * u2 + 120 * u3,
                           -24 * u + 84 * u2 - 60 * u3,
                           0.5 * (6 * u - 24 * u2 + 20 * u3)};
    auto blend = [&](const double* B, double scale) {
      return Eigen::VectorXd(scale * (B[0] * q_[k] + B[1] * h * qd_[k] + B[2] * h * h * qdd_[k] +
                                      B[3] * q_[k + 1] + B[4] * h * qd_[k + 1] +
                                      B[5] * h * h * qdd_[k + 1]));
    };
    const double t_last = t0_ + dt_ * static_cast<double>(q_.size() - 1);
    if (t < t0_ || t > t_last) {  // before or after: at rest at the end sample
      const size_t i = t < t0_ ? 0 : q_.size() - 1;
      return {q_[i], Eigen::VectorXd::Zero(q_[i].size()), Eigen::VectorXd::Zero(q_[i].size())};
    }
    return {blend(H, 1.0), blend(dH, 1 / h), blend(ddH, 1 / (h * h))};
  }

 private:
  double t0_, dt_;
  std::vector<Eigen::VectorXd> q_, qd_, qdd_;
};

// Per-joint gains: stiffness kp and damping kd (in torque units for PdController, in
// acceleration units, 1/s^2 and 1/s, for ComputedTorqueController).
struct JointGains {
  Eigen::VectorXd kp, kd;
  // Critically damped error dynamics e'' + kd e' + kp e = 0 of natural frequency omega.
  static JointGains critically_damped(int joints, double omega) {
    return {Eigen::VectorXd::Constant(joints, omega * omega),
            Eigen::VectorXd::Constant(joints, 2 * omega)};
  }
};

// tau = Kp (q_d - q) + Kd (qd_d - qd) on the link side.
class PdController {
 public:
  explicit PdController(JointGains gains) : gains_(std::move(gains)) {}
  Eigen::VectorXd torque(const JointTarget& target, const Eigen::VectorXd& q_joints,
                         const Eigen::VectorXd& qd_joints) const {
    return gains_.kp.cwiseProduct(target.q - q_joints) +
           gains_.kd.cwiseProduct(target.qd - qd_joints);
  }

 private:
  JointGains gains_;
};

// Inverse dynamics of the control model with the base free, from the plant's base state and
// link-side joint state mapped into the control model's coordinates (motor angles p q of a
// rigid gear; a flexible joint's motor at p q, the spring untwisted). With a = the commanded
// link-side joint accelerations (motor ones p a): M_bb a_b = -(M_b,rest a_rest + h_b), then
// r = M a + h, and tau_j = p_j r_motor(j) (+ r_link(j) for a flexible joint: the spring would
// carry it, the k -> infinity limit). h = b + springs, dampers and friction; where the model
// has the latter, h is read as -M qdd(Q = 0) from its forward dynamics (so friction is
// compensated too).
class ComputedTorqueController {
 public:
  // Keeps a copy of `control`, whose functions refer to the model it was made from (keep that
  // alive).
  ComputedTorqueController(const DynamicModel& control, JointGains gains)
      : model_(control), gains_(std::move(gains)) {
    if (!model_.mass_matrix_and_bias || !model_.forward_dynamics)
      throw std::invalid_argument("ComputedTorqueController: the control model '" + model_.name +
                                  "' must emit mass_matrix, bias_forces and forward_dynamics");
    if (gains_.kp.size() != model_.num_links || gains_.kd.size() != model_.num_links)
      throw std::invalid_argument("ComputedTorqueController: kp and kd need one gain per joint (" +
                                  std::to_string(model_.num_links) + ")");
  }

  const DynamicModel& model() const { return model_; }

  // tau for the plant's base pose and rates (num_base values each) and link-side joint state.
  Eigen::VectorXd torque(const JointTarget& target, const Eigen::VectorXd& base_q,
                         const Eigen::VectorXd& base_qd, const Eigen::VectorXd& q_joints,
                         const Eigen::VectorXd& qd_joints) const {
    const Eigen::VectorXd a = target.qdd + gains_.kd.cwiseProduct(target.qd - qd_joints) +
                              gains_.kp.cwiseProduct(target.q - q_joints);
    return inverse_dynamics(base_q, base_qd, q_joints, qd_joints, a);
  }

  // Link-side joint torques for link-side joint accelerations a, no force on the base.
  Eigen::VectorXd inverse_dynamics(const Eigen::VectorXd& base_q, const Eigen::VectorXd& base_qd,
                                   const Eigen::VectorXd& q_joints,
                                   const Eigen::VectorXd& qd_joints,
                                   const Eigen::VectorXd& a) const {
    const int nv = model_.nv, nb = model_.num_base(), N = model_.num_links;
    const int nbq = model_.base_coordinates();  // nb, and one more for a quaternion
    if (base_q.size() != nbq || base_qd.size() != nb || q_joints.size() != N ||
        qd_joints.size() != N || a.size() != N)
      throw std::invalid_argument("ComputedTorqueController: the control model '" + model_.name +
                                  "' takes " + std::to_string(nbq) + " base coordinates, " +
                                  std::to_string(nb) + " base rates and " + std::to_string(N) +
                                  " joint values (a plant with another base or joint count?)");
    // The state with each motor at p times its joint (a flexible joint's spring relaxed).
    const Eigen::VectorXd q = model_.from_joint_angles(base_q, q_joints);
    const Eigen::VectorXd qd = model_.from_joint_rates(base_qd, qd_joints);
    Eigen::VectorXd acc = model_.from_joint_rates(Eigen::VectorXd::Zero(nb), a);
    Eigen::MatrixXd M;
    Eigen::VectorXd b;
    model_.mass_matrix_and_bias(q, qd, M, b);
    // Springs, dampers and friction only where the model has them: else h is the bias itself.
    const Eigen::VectorXd h =
        model_.passive_forces
            ? Eigen::VectorXd(-M * model_.forward_dynamics(q, qd, Eigen::VectorXd::Zero(nv)))
            : b;
    if (nb > 0)
      acc.head(nb) = -M.topLeftCorner(nb, nb).ldlt().solve(
          M.block(0, nb, nb, nv - nb) * acc.tail(nv - nb) + h.head(nb));
    const Eigen::VectorXd r = M * acc + h;
    Eigen::VectorXd tau(N);
    for (int j = 0; j < N; ++j) {
      const int slot = nb + j, motor = model_.actuated_coordinates[j];
      tau[j] = model_.gear_ratios[j] * r[motor] + (motor == slot ? 0.0 : r[slot]);
    }
    return tau;
  }

 private:
  DynamicModel model_;
  JointGains gains_;
};

// Runs a sampled controller on a plant: every `period` from t = 0 the controller reads the
// plant's state (t, q, qd) and returns link-side joint torques, held until the next sample;
// record(t, q, qd, tau) sees each sample with the torque decided there. The integrator steps
// land on the samples (a step never straddles a torque change): rk4 and implicit_midpoint
// need `period` to be a multiple of options.dt; rosenbrock4 uses the plant's state Jacobian
// (the held torque does not depend on the state within a step).
template <class Control, class Record>
IntegrationStats integrate_closed_loop(const DynamicModel& plant, const Eigen::VectorXd& q0,
                                       const Eigen::VectorXd& qd0, Control&& control, double period,
                                       double t_end, IntegratorOptions options, Record&& record) {
  const long samples = std::isfinite(t_end / period) ? std::lround(t_end / period) : 0;
  if (!(period > 0) || samples < 1 || std::abs(samples * period - t_end) > 1e-9 * t_end)
    throw std::invalid_argument("integrate_closed_loop: t_end = " + number_text(t_end) +
                                " must be a positive multiple of the control period " +
                                number_text(period));
  Eigen::VectorXd held = Eigen::VectorXd::Zero(plant.num_links);
  // The held torque, for every stage of the steps up to the next sample (evaluate copies it
  // into the integrator's workspace: nothing allocated per step).
  struct Held {
    const Eigen::VectorXd& value;
    Eigen::VectorXd operator()(double) const { return value; }
    void evaluate(double, Eigen::VectorXd& out) const { out = value; }
  } torque{held};
  auto sample = [&](double t, const Eigen::VectorXd& q, const Eigen::VectorXd& qd) {
    held = control(t, q, qd);
    if (held.size() != plant.num_links || !held.allFinite())
      throw std::runtime_error("integrate_closed_loop: the controller's torque at t = " +
                               number_text(t) + " is not finite or has the wrong size");
    record(t, q, qd, held);
  };
  if (adaptive(options.method)) {
    options.breakpoint_interval = period;  // controlled steps that land on every sample
    options.breakpoint_origin = 0;
  }
  return integrate_motion(plant, q0, qd0, torque, t_end, period, options, sample);
}

}  // namespace spacearm
