// The dynamic-size runtime model: one interface for code whose sizes are known only at run time
// (a loaded CompiledModel, jit/) and for algorithms written once for every model (the planner,
// simulate() behind the CLI). A linked Model<G> converts to it with dynamic_model(). Its
// functions are the model's own, so the checks are shared: forward_dynamics throws the same
// DynamicsError (dynamics_checks.hpp) whichever model is behind it.
#pragma once

#include <Eigen/Core>

#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "model.hpp"

namespace spacearm {

struct DynamicModel {
  using Vector = Eigen::VectorXd;       // configuration q (nq)
  using Velocity = Eigen::VectorXd;     // qd, qdd, generalized forces Q, bias b (nv)
  using JointVector = Eigen::VectorXd;  // one value per joint
  using Vector3 = Eigen::Vector3d;
  using Matrix = Eigen::MatrixXd;                 // nv x nv
  using ConfigurationJacobian = Eigen::MatrixXd;  // nv x nq

  std::string name;
  int nq = 0, nv = 0, num_links = 0;
  bool free_floating = false;
  std::vector<std::string> coordinate_names;  // nq names
  Eigen::VectorXd gear_ratios;  // per joint: link-side torque = p * generalized force (eq. 14)
  // Per joint, the velocity index its torque drives: the joint's slot (num_base() + i), or the
  // motor coordinate of a flexible joint (after all joint slots).
  std::vector<int> actuated_coordinates;
  // Springs, dampers or friction act besides M qdd + b (forward_dynamics includes them;
  // mass_matrix_and_bias alone does not describe the dynamics).
  bool passive_forces = false;

  // Each function is empty where the scene does not emit what it needs.
  std::function<Vector3(const Vector& q)> end_effector_pose;
  std::function<Eigen::MatrixXd(const Vector& q)> end_effector_jacobian;  // 3 x nv
  std::function<void(const Vector& q, const Velocity& qd, Eigen::MatrixXd& M, Velocity& b)>
      mass_matrix_and_bias;
  // qdd = M^-1 (Q - b), eq. 8, with check_forward_dynamics (DynamicsError).
  std::function<Velocity(const Vector& q, const Velocity& qd, const Velocity& Q)> forward_dynamics;
  // The state Jacobian dqdd/dq (nv x nq), dqdd/dqd (nv x nv) at constant Q; returns qdd.
  std::function<Velocity(const Vector& q, const Velocity& qd, const Velocity& Q,
                         ConfigurationJacobian& dqdd_dq, Matrix& dqdd_dqd)>
      forward_dynamics_derivatives;
  std::function<double(const Vector& q, const Velocity& qd)> kinetic_energy;
  std::function<Vector3(const Vector& q, const Velocity& qd)> momentum;  // [Px, Py, L]
  std::function<double(const Vector& q)> potential_energy;               // V of the joint springs
  std::function<Velocity(const Velocity& qd)> friction_forces;  // f(w) on each velocity (nv)

  // The layout as data, not as the plane's numbers: the base's velocities (0 for a fixed base)
  // and, per joint, the index of its slot in q and in v (equal while nq = nv). set_layout fills
  // them; every adapter (dynamic_model of a linked or a loaded model) calls it.
  int base_velocities = 0;
  std::vector<int> joint_q_offsets, joint_v_offsets;
  // The joint slots follow the base's num_base velocities (and its coordinates: a quaternion's
  // extra entry shifts the q offsets by one).
  void set_layout(int num_base, int quaternion_offset) {
    base_velocities = num_base;
    joint_q_offsets.clear();
    joint_v_offsets.clear();
    for (int i = 0; i < num_links; ++i) {
      joint_v_offsets.push_back(num_base + i);
      joint_q_offsets.push_back(num_base + i + (quaternion_offset >= 0 ? 1 : 0));
    }
  }
  int num_base() const { return base_velocities; }
  bool has_state_jacobian() const { return static_cast<bool>(forward_dynamics_derivatives); }
  // Only the base and one slot per joint: no flexible joint's motor coordinates. The planner
  // and the CLI's link-side columns need it.
  bool rigid_joints() const { return nv == num_base() + num_links; }

  // dq/dt for velocity qd: the identity for every planar model (Model::configuration_rate).
  Velocity configuration_rate(const Vector& /*q*/, const Velocity& qd) const {
    if (nq != nv) throw std::logic_error("model " + name + ": configuration_rate needs nq == nv");
    return qd;
  }

  // Link-side joint angles (or rates, from qd): a slot that the joint's torque drives holds the
  // motor angle qm = p q (eq. 12; p = 1 without a gear); a flexible joint's slot holds q itself.
  JointVector joint_angles(const Eigen::VectorXd& x) const {
    JointVector a(num_links);
    for (int i = 0; i < num_links; ++i) {
      const int slot = joint_q_offsets.at(i);
      a[i] =
          actuated_coordinates.at(i) == joint_v_offsets.at(i) ? x[slot] / gear_ratios[i] : x[slot];
    }
    return a;
  }

  // Whether joint j's slot holds a motor angle (a rigid gear: qm_j, not q_j), so that tables add
  // its link-side angle q_j = qm_j / p_j as a column of its own.
  bool slot_holds_motor(int j) const {
    return coordinate_names.at(joint_q_offsets.at(j)) != "q" + std::to_string(j + 1);
  }

  // The joint angles (or rates, from qd) that the motor encoders read: qm / p of the coordinate
  // each joint's torque drives (q itself without a gear). Feedback from them is collocated with
  // the torque: it stays stable with flexible joints, where link-side feedback may not.
  JointVector motor_side(const Eigen::VectorXd& x) const {
    JointVector a(num_links);
    for (int i = 0; i < num_links; ++i) a[i] = x[actuated_coordinates.at(i)] / gear_ratios[i];
    return a;
  }

  // The configuration (or velocity, from rates) with the base pose `base` and link-side joint
  // angles: joint_angles' inverse. A flexible joint's motor angle is p q, its spring relaxed
  // (consistent_start.hpp pre-deflects it).
  Vector from_joint_angles(const Eigen::VectorXd& base, const JointVector& angles) const {
    Vector x(nq);
    x.head(num_base()) = base;
    for (int i = 0; i < num_links; ++i) {
      const int slot = joint_q_offsets.at(i), motor = actuated_coordinates.at(i);
      const bool on_slot = motor == joint_v_offsets.at(i);  // a rigid gear's motor angle
      x[slot] = on_slot ? gear_ratios[i] * angles[i] : angles[i];
      if (!on_slot) x[motor] = gear_ratios[i] * angles[i];
    }
    return x;
  }

  // Joint (or motor) torques as generalized forces, Q = tau / p on the joints, eq. 14.
  Velocity generalized_forces(const JointVector& tau) const {
    Velocity Q = Velocity::Zero(nv);
    for (int i = 0; i < num_links; ++i) Q[actuated_coordinates.at(i)] = tau[i] / gear_ratios[i];
    return Q;
  }
};

// A linked model at its current parameter values, at dynamic size. The result refers to m:
// keep m alive while it is used. Vectors passed to it must have the model's sizes (nq, nv).
template <class G>
DynamicModel dynamic_model(const Model<G>& m) {
  using M = Model<G>;
  DynamicModel d;
  d.name = M::name();
  d.nq = M::kNq;
  d.nv = M::kNv;
  d.num_links = M::kNumLinks;
  d.free_floating = M::kFreeFloating;
  d.coordinate_names.assign(M::coordinate_names().begin(), M::coordinate_names().end());
  d.gear_ratios = m.gear_ratios();
  const auto actuated = M::actuated_coordinates();
  d.actuated_coordinates.assign(actuated.begin(), actuated.end());
  d.passive_forces = M::kHasPassiveForces;
  d.set_layout(M::kFirstJoint, -1);
  // Only what the scene emits (the Model<G> functions of an absent output do not exist).
  if constexpr (G::kHas_end_effector_pose)
    d.end_effector_pose = [&m](const Eigen::VectorXd& q) {
      return Eigen::Vector3d(m.end_effector_pose(q));
    };
  if constexpr (G::kHas_end_effector_jacobian)
    d.end_effector_jacobian = [&m](const Eigen::VectorXd& q) {
      return Eigen::MatrixXd(m.end_effector_jacobian(q));
    };
  if constexpr (G::kHas_mass_matrix && G::kHas_bias_forces)
    d.mass_matrix_and_bias = [&m](const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                  Eigen::MatrixXd& Mq, Eigen::VectorXd& b) {
      typename M::Matrix Mf;
      typename M::Velocity bf;
      m.mass_matrix_and_bias(q, qd, Mf, bf);
      Mq = Mf;
      b = bf;
    };
  if constexpr (G::kHas_forward_dynamics ||
                (G::kHas_mass_matrix && G::kHas_bias_forces && !M::kHasPassiveForces))
    d.forward_dynamics = [&m](const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                              const Eigen::VectorXd& Q) {
      return Eigen::VectorXd(m.forward_dynamics(q, qd, Q));
    };
  if constexpr (M::kHasStateJacobian)
    d.forward_dynamics_derivatives = [&m](const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                          const Eigen::VectorXd& Q, Eigen::MatrixXd& dqdd_dq,
                                          Eigen::MatrixXd& dqdd_dqd) {
      typename M::ConfigurationJacobian dq;
      typename M::Matrix dqd;
      const Eigen::VectorXd qdd = m.forward_dynamics_derivatives(q, qd, Q, dq, dqd);
      dqdd_dq = dq;
      dqdd_dqd = dqd;
      return qdd;
    };
  if constexpr (G::kHas_kinetic_energy)
    d.kinetic_energy = [&m](const Eigen::VectorXd& q, const Eigen::VectorXd& qd) {
      return m.kinetic_energy(q, qd);
    };
  if constexpr (M::kHasPotentialEnergy)
    d.potential_energy = [&m](const Eigen::VectorXd& q) { return m.potential_energy(q); };
  if constexpr (M::kHasFrictionForces)
    d.friction_forces = [&m](const Eigen::VectorXd& qd) {
      return Eigen::VectorXd(m.friction_forces(qd));
    };
  if constexpr (G::kHas_momentum)
    d.momentum = [&m](const Eigen::VectorXd& q, const Eigen::VectorXd& qd) {
      return Eigen::Vector3d(m.momentum(q, qd));
    };
  return d;
}

}  // namespace spacearm
