// The dynamic-size runtime model: one interface for code whose sizes are known only at run time
// (a loaded CompiledModel, jit/) and for algorithms written once for every model (the planner,
// simulate() behind the CLI). dynamic_model() builds it, the same way for every model, from a
// source: LinkedSource (a linked Model<G>, below) or jit's LoadedSource. Its functions are the
// model's own, so the checks are shared: forward_dynamics throws the same DynamicsError
// (dynamics_checks.hpp) whichever model is behind it.
#pragma once

#include <Eigen/Core>

#include <cctype>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "configuration_space.hpp"
#include "model.hpp"

namespace spacearm {

// Joint (or motor) torques tau as generalized forces (eq. 14): Q = tau_i / p_i on the coordinate
// joint i drives (its slot, or a flexible joint's motor coordinate), 0 elsewhere. The one place
// that divides by the ratios: DynamicModel and `eval --tau` call it.
inline void joint_torques_as_forces(const Eigen::VectorXd& tau, const Eigen::VectorXd& ratios,
                                    const std::vector<int>& actuated,
                                    Eigen::Ref<Eigen::VectorXd> Q) {
  Q.setZero();
  for (int i = 0; i < ratios.size(); ++i) Q[actuated.at(i)] = tau[i] / ratios[i];
}

// What a model states about itself, whichever way it was built.
struct DynamicModelFacts {
  std::string name;
  int nq = 0, nv = 0, num_links = 0;
  bool free_floating = false;
  std::vector<std::string> coordinate_names;  // nq names
  Eigen::VectorXd gear_ratios;  // per joint: link-side torque = p * generalized force (eq. 14)
  // Per joint, the velocity index its torque drives: the joint's slot (num_base() + i), or the
  // motor coordinate of a flexible joint (after all joint slots).
  std::vector<int> actuated_coordinates;
  // Per joint: its slot in q holds the motor angle qm = p q (a rigid gear, eq. 12).
  std::vector<bool> motor_angle_slots;
  // Springs, dampers or friction act besides M qdd + b (forward_dynamics includes them;
  // mass_matrix_and_bias alone does not describe the dynamics).
  bool passive_forces = false;
  // The base's velocities (0 for a fixed base) and where a quaternion sits in q (-1: none).
  int base_velocities = 0, quaternion_offset = -1;
  // In 3D: the pose is [x, y, z, qw, qx, qy, qz], the momentum [P (3), L (3)]; in the plane
  // [x, y, phi] and [Px, Py, L].
  bool spatial = false;
  // A tree's end effectors, whose poses follow one another (empty: one end effector).
  std::vector<std::string> end_effector_names;
  int num_end_effectors() const {
    return end_effector_names.empty() ? 1 : static_cast<int>(end_effector_names.size());
  }
};

struct DynamicModel : DynamicModelFacts {
  using Vector = Eigen::VectorXd;           // configuration q (nq)
  using Velocity = Eigen::VectorXd;         // qd, qdd, generalized forces Q, bias b (nv)
  using JointVector = Eigen::VectorXd;      // one value per joint
  using Pose = Eigen::VectorXd;             // the registry's pose: [x, y, phi] in the plane
  using Momentum = Eigen::VectorXd;         // [Px, Py, L] in the plane
  using Matrix = Eigen::MatrixXd;           // nv x nv
  using TangentJacobian = Eigen::MatrixXd;  // nv x nv, on q's tangent space

  // The functions a source may have; dynamic_model() asks it for each.
  enum class Function {
    end_effector_pose,
    end_effector_jacobian,
    mass_matrix_and_bias,
    forward_dynamics,  // emitted, or M and b without passive forces (a Cholesky solve)
    forward_dynamics_derivatives,
    kinetic_energy,
    potential_energy,
    friction_forces,
    momentum,
  };

  // Each function is empty where the scene does not emit what it needs.
  std::function<Pose(const Vector& q)> end_effector_pose;
  std::function<Eigen::MatrixXd(const Vector& q)> end_effector_jacobian;  // twist x nv
  std::function<void(const Vector& q, const Velocity& qd, Eigen::MatrixXd& M, Velocity& b)>
      mass_matrix_and_bias;
  // qdd = M^-1 (Q - b), eq. 8, with check_forward_dynamics (DynamicsError).
  std::function<Velocity(const Vector& q, const Velocity& qd, const Velocity& Q)> forward_dynamics;
  // forward_dynamics into caller storage (q: nq entries; qd, Q, qdd: nv), for a caller that
  // calls it many times (an integration): the same results and errors, on a workspace of its
  // own, allocating nothing per call where the source can (a loaded model that emits
  // forward_dynamics; a linked one). make_forward_dynamics_call() makes one: not reentrant, so
  // one per integration and thread.
  using ForwardDynamicsCall =
      std::function<void(const double* q, const double* qd, const double* Q, double* qdd)>;
  std::function<ForwardDynamicsCall()> make_forward_dynamics_call;
  // The state Jacobian dqdd/dq (nv x nv, on q's tangent space), dqdd/dqd (nv x nv) at constant
  // Q; returns qdd.
  std::function<Velocity(const Vector& q, const Velocity& qd, const Velocity& Q,
                         TangentJacobian& dqdd_dq, Matrix& dqdd_dqd)>
      forward_dynamics_derivatives;
  // The same and dqdd/dtau (nv x N, by the link-side joint torques), from the same call.
  std::function<Velocity(const Vector& q, const Velocity& qd, const Velocity& Q,
                         TangentJacobian& dqdd_dq, Matrix& dqdd_dqd, Matrix& dqdd_dtau)>
      state_and_torque_jacobian;
  std::function<double(const Vector& q, const Velocity& qd)> kinetic_energy;
  std::function<Momentum(const Vector& q, const Velocity& qd)> momentum;
  std::function<double(const Vector& q)> potential_energy;      // V of the joint springs
  std::function<Velocity(const Velocity& qd)> friction_forces;  // f(w) on each velocity (nv)

  // The layout as data, not as the plane's numbers: per joint, the index of its slot in q and
  // in v (equal while nq = nv). set_layout fills them from the facts; dynamic_model() calls it.
  std::vector<int> joint_q_offsets, joint_v_offsets;
  // The joint slots follow the base's velocities (and its coordinates: a quaternion's extra
  // entry shifts the q offsets by one).
  void set_layout(int num_base, int quaternion) {
    base_velocities = num_base;
    quaternion_offset = quaternion;
    joint_q_offsets.clear();
    joint_v_offsets.clear();
    for (int i = 0; i < num_links; ++i) {
      joint_v_offsets.push_back(num_base + i);
      joint_q_offsets.push_back(num_base + i + (quaternion >= 0 ? 1 : 0));
    }
  }
  int num_base() const { return base_velocities; }
  // The configuration at rest: zeros, and the identity rotation (w = 1) for a quaternion.
  Vector neutral_configuration() const { return configuration_space().neutral(); }
  // A name per velocity: a coordinate's name with "d" where v is its rate; with a quaternion,
  // the base's world velocity vx0, vy0, vz0 and its angular velocity in its own frame wx0..wz0.
  std::vector<std::string> velocity_names() const {
    std::vector<std::string> names;
    int first = 0;
    if (quaternion_offset >= 0) {
      names = {"vx0", "vy0", "vz0", "wx0", "wy0", "wz0"};
      first = base_coordinates();
    }
    for (size_t i = first; i < coordinate_names.size(); ++i)
      names.push_back(coordinate_names[i] + "d");
    return names;
  }
  // The base's entries in q: its velocities' count, plus one for a quaternion.
  int base_coordinates() const { return base_velocities + (quaternion_offset >= 0 ? 1 : 0); }
  // The index in q of velocity index v past the base (a joint slot or a motor coordinate).
  int q_index(int v) const { return v + base_coordinates() - base_velocities; }
  bool has_state_jacobian() const { return static_cast<bool>(forward_dynamics_derivatives); }
  // std::invalid_argument, for `who` (a command or function), if the model has no forward
  // dynamics, naming what its scene must emit.
  void require_forward_dynamics(const std::string& who) const {
    if (forward_dynamics) return;
    throw std::invalid_argument(
        who + (passive_forces ? ": a scene with springs, dampers or friction must emit "
                                "forward_dynamics (field 'outputs')"
                              : ": the scene must emit forward_dynamics, or mass_matrix and "
                                "bias_forces (field 'outputs')"));
  }
  // Only the base and one slot per joint: no flexible joint's motor coordinates. The planner
  // and the CLI's link-side columns need it.
  bool rigid_joints() const { return nv == num_base() + num_links; }

  // The configuration space (configuration_space.hpp) and dq/dt for velocity qd: the identity
  // for every planar model, the quaternion's rate for a base floating in 3D.
  ConfigurationSpace configuration_space() const { return {nq, nv, quaternion_offset}; }
  Vector configuration_rate(const Vector& q, const Velocity& qd) const {
    return configuration_space().rate(q, qd);
  }

  // Link-side joint angles from q: a slot that holds the motor angle qm = p q (eq. 12) is
  // divided by p; any other slot holds q itself. joint_rates does the same for qd.
  JointVector joint_angles(const Vector& q) const { return link_side(q, joint_q_offsets, nq); }
  JointVector joint_rates(const Velocity& qd) const { return link_side(qd, joint_v_offsets, nv); }
  // Joint j's link-side rate or angle alone (nothing allocated: a sweep's step reads them).
  double joint_rate(const Velocity& qd, int j) const {
    return link_side_value(qd[joint_v_offsets[j]], j);
  }
  double joint_angle(const Vector& q, int j) const {
    return link_side_value(q[joint_q_offsets[j]], j);
  }

  // Whether joint j's slot holds a motor angle (a rigid gear: qm_j, not q_j), so that tables add
  // its link-side angle q_j = qm_j / p_j as a column of its own.
  bool slot_holds_motor(int j) const { return motor_angle_slots.at(j); }

  // The joint angles (from q) or rates (from qd) that the motor encoders read: qm / p of the
  // coordinate each joint's torque drives (q itself without a gear). Feedback from them is
  // collocated with the torque: it stays stable with flexible joints, where link-side feedback
  // may not.
  JointVector motor_side(const Vector& q) const { return motor_angles(q, nq); }
  JointVector motor_side_rates(const Velocity& qd) const { return motor_angles(qd, nv); }

  // The configuration with the base pose `base` and link-side joint angles: joint_angles'
  // inverse. A flexible joint's motor angle is p q, its spring relaxed (consistent_start.hpp
  // pre-deflects it). from_joint_rates does the same for the velocity.
  Vector from_joint_angles(const Eigen::VectorXd& base, const JointVector& angles) const {
    return assembled(base, angles, joint_q_offsets, nq);
  }
  Velocity from_joint_rates(const Eigen::VectorXd& base_rate, const JointVector& rates) const {
    return assembled(base_rate, rates, joint_v_offsets, nv);
  }

  // Joint (or motor) torques as generalized forces, Q = tau / p on the joints, eq. 14.
  Velocity generalized_forces(const JointVector& tau) const {
    Velocity Q(nv);
    generalized_forces(tau, Q);
    return Q;
  }
  // The same into Q (nv entries): no allocation.
  void generalized_forces(const JointVector& tau, Eigen::Ref<Velocity> Q) const {
    joint_torques_as_forces(tau, gear_ratios, actuated_coordinates, Q);
  }

 private:
  // A velocity index past the base in a vector of q's size or of v's.
  int index_in(Eigen::Index size, int v) const { return size == nv ? v : q_index(v); }
  // A slot's value on the link side: qm / p where it holds a rigid gear's motor angle.
  double link_side_value(double slot, int j) const {
    return slot_holds_motor(j) ? slot / gear_ratios[j] : slot;
  }
  JointVector link_side(const Eigen::VectorXd& x, const std::vector<int>& offsets, int size) const {
    check_size(x, size);
    JointVector a(num_links);
    for (int i = 0; i < num_links; ++i) {
      a[i] = link_side_value(x[offsets.at(i)], i);
    }
    return a;
  }
  JointVector motor_angles(const Eigen::VectorXd& x, int size) const {
    check_size(x, size);
    JointVector a(num_links);
    for (int i = 0; i < num_links; ++i)
      a[i] = x[index_in(size, actuated_coordinates.at(i))] / gear_ratios[i];
    return a;
  }
  Eigen::VectorXd assembled(const Eigen::VectorXd& base, const JointVector& angles,
                            const std::vector<int>& offsets, int size) const {
    const int base_size = size == nv ? num_base() : base_coordinates();
    if (base.size() != base_size || angles.size() != num_links)
      throw std::invalid_argument("model " + name + ": expected " + std::to_string(base_size) +
                                  " base and " + std::to_string(num_links) + " joint values, got " +
                                  std::to_string(base.size()) + " and " +
                                  std::to_string(angles.size()));
    Eigen::VectorXd x(size);
    x.head(base_size) = base;
    for (int i = 0; i < num_links; ++i) {
      const double p = gear_ratios[i];
      x[offsets.at(i)] = slot_holds_motor(i) ? p * angles[i] : angles[i];
      const int motor = actuated_coordinates.at(i);
      if (motor != joint_v_offsets.at(i)) x[index_in(size, motor)] = p * angles[i];
    }
    return x;
  }
  void check_size(const Eigen::VectorXd& x, int size) const {
    if (x.size() != size)
      throw std::invalid_argument("model " + name + ": expected " + std::to_string(size) +
                                  " values, got " + std::to_string(x.size()));
  }
};

// The end-effector pose's columns of a table (simulate's and plan's): ee_x, ee_y, ee_phi in
// the plane, ee_x..ee_z and the quaternion ee_qw..ee_qz in 3D; none without the output.
inline std::vector<std::string> end_effector_columns(bool spatial) {
  if (spatial) return {"ee_x", "ee_y", "ee_z", "ee_qw", "ee_qx", "ee_qy", "ee_qz"};
  return {"ee_x", "ee_y", "ee_phi"};
}
// The momentum's columns, linear then angular: Px, Py, L in the plane, Px..Pz, Lx..Lz in 3D;
// none without the output.
inline std::vector<std::string> momentum_columns(const DynamicModel& m) {
  if (!m.momentum) return {};
  if (m.spatial) return {"Px", "Py", "Pz", "Lx", "Ly", "Lz"};
  return {"Px", "Py", "L"};
}
// Several end effectors (a tree's): each one's columns, ee_NAME_x or (a name that is not a
// short identifier: untrusted text stays out of a table's header) eeK_x.
inline std::vector<std::string> end_effector_columns(const DynamicModel& m) {
  if (!m.end_effector_pose) return {};
  const std::vector<std::string> one = end_effector_columns(m.spatial);
  if (m.num_end_effectors() == 1) return one;
  std::vector<std::string> columns;
  for (int e = 0; e < m.num_end_effectors(); ++e) {
    const std::string& name = m.end_effector_names[e];
    bool identifier = !name.empty() && name.size() <= 64 && !std::isdigit(name[0]);
    for (unsigned char c : name) identifier = identifier && (std::isalnum(c) || c == '_');
    const std::string prefix = identifier ? "ee_" + name + "_" : "ee" + std::to_string(e + 1) + "_";
    for (const std::string& c : one) columns.push_back(prefix + c.substr(3));
  }
  return columns;
}

// The one adapter. A Source states the model's facts (facts()), whether it has each function
// (has(DynamicModel::Function)) and calls them at dynamic size under the names of DynamicModel's
// members; a function it lacks need not work. The result holds copies of the source: keep
// the model behind it alive and in place while the result is used.
template <class Source>
DynamicModel dynamic_model_of(const Source& s) {
  using F = DynamicModel::Function;
  using V = Eigen::VectorXd;
  using Mx = Eigen::MatrixXd;
  DynamicModel d;
  static_cast<DynamicModelFacts&>(d) = s.facts();
  d.set_layout(d.base_velocities, d.quaternion_offset);
  if (s.has(F::end_effector_pose))
    d.end_effector_pose = [s](const V& q) { return s.end_effector_pose(q); };
  if (s.has(F::end_effector_jacobian))
    d.end_effector_jacobian = [s](const V& q) { return s.end_effector_jacobian(q); };
  if (s.has(F::mass_matrix_and_bias))
    d.mass_matrix_and_bias = [s](const V& q, const V& qd, Mx& M, V& b) {
      s.mass_matrix_and_bias(q, qd, M, b);
    };
  if (s.has(F::forward_dynamics)) {
    d.forward_dynamics = [s](const V& q, const V& qd, const V& Q) {
      return s.forward_dynamics(q, qd, Q);
    };
    d.make_forward_dynamics_call = [s] { return s.forward_dynamics_call(); };
  }
  if (s.has(F::forward_dynamics_derivatives)) {
    d.forward_dynamics_derivatives = [s](const V& q, const V& qd, const V& Q, Mx& dq, Mx& dqd) {
      return s.forward_dynamics_derivatives(q, qd, Q, dq, dqd);
    };
    d.state_and_torque_jacobian = [s](const V& q, const V& qd, const V& Q, Mx& dq, Mx& dqd,
                                      Mx& dtau) {
      return s.forward_dynamics_derivatives(q, qd, Q, dq, dqd, &dtau);
    };
  }
  if (s.has(F::kinetic_energy))
    d.kinetic_energy = [s](const V& q, const V& qd) { return s.kinetic_energy(q, qd); };
  if (s.has(F::potential_energy))
    d.potential_energy = [s](const V& q) { return s.potential_energy(q); };
  if (s.has(F::friction_forces))
    d.friction_forces = [s](const V& qd) { return s.friction_forces(qd); };
  if (s.has(F::momentum)) d.momentum = [s](const V& q, const V& qd) { return s.momentum(q, qd); };
  return d;
}

// A linked Model<G> as a source of dynamic_model_of: the generated header's flags say what it
// has; a function it lacks is never instantiated (Model<G> does not declare it).
template <class G>
class LinkedSource {
 public:
  using M = Model<G>;
  using F = DynamicModel::Function;
  using V = Eigen::VectorXd;
  using Mx = Eigen::MatrixXd;
  explicit LinkedSource(const M& m) : m_(&m) {}

  static constexpr bool has(F f) {
    switch (f) {
      case F::end_effector_pose:
        return G::kHas_end_effector_pose;
      case F::end_effector_jacobian:
        return G::kHas_end_effector_jacobian;
      case F::mass_matrix_and_bias:
        return G::kHas_mass_matrix && G::kHas_bias_forces;
      case F::forward_dynamics:
        return M::kHasForwardDynamics;
      case F::forward_dynamics_derivatives:
        return M::kHasStateJacobian;
      case F::kinetic_energy:
        return G::kHas_kinetic_energy;
      case F::potential_energy:
        return M::kHasPotentialEnergy;
      case F::friction_forces:
        return M::kHasFrictionForces;
      case F::momentum:
        return G::kHas_momentum;
    }
    return false;
  }

  DynamicModelFacts facts() const {
    DynamicModelFacts f;
    f.name = M::name();
    f.nq = M::kNq;
    f.nv = M::kNv;
    f.num_links = M::kNumLinks;
    f.free_floating = M::kFreeFloating;
    f.coordinate_names.assign(M::coordinate_names().begin(), M::coordinate_names().end());
    f.gear_ratios = m_->gear_ratios();
    const auto actuated = M::actuated_coordinates();
    f.actuated_coordinates.assign(actuated.begin(), actuated.end());
    const auto motor_angle_slots = M::motor_angle_slots();
    f.motor_angle_slots.assign(motor_angle_slots.begin(), motor_angle_slots.end());
    f.passive_forces = M::kHasPassiveForces;
    f.base_velocities = M::kNumBase;
    f.quaternion_offset = M::kQuaternionOffset;
    f.spatial = M::kSpatial;
    constexpr int poses = M::kNumEndEffectors;
    for (int e = 0; poses > 1 && e < poses; ++e)
      f.end_effector_names.push_back("end_effector_" + std::to_string(e + 1));
    return f;
  }

  V end_effector_pose(const V& q) const {
    if constexpr (has(F::end_effector_pose)) return V(m_->end_effector_pose(q));
    absent();
  }
  Mx end_effector_jacobian(const V& q) const {
    if constexpr (has(F::end_effector_jacobian)) return Mx(m_->end_effector_jacobian(q));
    absent();
  }
  void mass_matrix_and_bias(const V& q, const V& qd, Mx& Mq, V& b) const {
    if constexpr (has(F::mass_matrix_and_bias)) {
      typename M::Matrix Mf;
      typename M::Velocity bf;
      m_->mass_matrix_and_bias(q, qd, Mf, bf);
      Mq = Mf;
      b = bf;
    } else {
      absent();
    }
  }
  V forward_dynamics(const V& q, const V& qd, const V& Q) const {
    if constexpr (has(F::forward_dynamics)) return V(m_->forward_dynamics(q, qd, Q));
    absent();
  }
  // At fixed size: nothing allocated.
  DynamicModel::ForwardDynamicsCall forward_dynamics_call() const {
    if constexpr (has(F::forward_dynamics)) {
      return [m = m_](const double* q, const double* qd, const double* Q, double* qdd) {
        using Vq = typename M::Vector;
        using Vv = typename M::Velocity;
        Eigen::Map<Vv> out(qdd);
        out = m->forward_dynamics(Eigen::Map<const Vq>(q), Eigen::Map<const Vv>(qd),
                                  Eigen::Map<const Vv>(Q));
      };
    }
    absent();
  }
  V forward_dynamics_derivatives(const V& q, const V& qd, const V& Q, Mx& dqdd_dq, Mx& dqdd_dqd,
                                 Mx* dqdd_dtau = nullptr) const {
    if constexpr (has(F::forward_dynamics_derivatives)) {
      typename M::TangentJacobian dq;
      typename M::Matrix dqd;
      typename M::TorqueJacobian dtau;
      const V qdd = m_->forward_dynamics_derivatives(q, qd, Q, dq, dqd, dtau);
      dqdd_dq = dq;
      dqdd_dqd = dqd;
      if (dqdd_dtau) *dqdd_dtau = dtau;
      return qdd;
    }
    absent();
  }
  double kinetic_energy(const V& q, const V& qd) const {
    if constexpr (has(F::kinetic_energy)) return m_->kinetic_energy(q, qd);
    absent();
  }
  double potential_energy(const V& q) const {
    if constexpr (has(F::potential_energy)) return m_->potential_energy(q);
    absent();
  }
  V friction_forces(const V& qd) const {
    if constexpr (has(F::friction_forces)) return V(m_->friction_forces(qd));
    absent();
  }
  V momentum(const V& q, const V& qd) const {
    if constexpr (has(F::momentum)) return V(m_->momentum(q, qd));
    absent();
  }

 private:
  const M* m_;
  // Never called: dynamic_model_of binds only what has() says.
  [[noreturn]] static void absent() {
    throw std::logic_error("LinkedSource: a function the model does not have was called");
  }
};

// A linked model at its current parameter values, at dynamic size. The result refers to m:
// keep m alive while it is used. Vectors passed to it must have the model's sizes (nq, nv).
template <class G>
DynamicModel dynamic_model(const Model<G>& m) {
  return dynamic_model_of(LinkedSource<G>(m));
}

}  // namespace spacearm
