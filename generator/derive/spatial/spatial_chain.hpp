// A tree of revolute joints in space (a serial chain the common case) on a base that floats in
// all six degrees of freedom (or is fixed): forward kinematics, body velocities, the mass matrix
// (CRBA), recursive Newton-Euler, forward dynamics, kinetic energy, momentum and the end
// effectors, written once
// over the scalar (double, and recorded_scalar.hpp's Sym and duals, as planar_chain.cpp is).
// The algebra is Featherstone's in body coordinates (spatial_algebra.hpp); what the chain is made
// of, its description (spatial_description.hpp).
//
// The free base follows MuJoCo's free joint, so a state passes between the two unconverted:
// q = [base origin in the world (3), unit quaternion w, x, y, z (4), joint angles],
// v = [velocity of the base origin in the world (3), angular velocity in the base frame (3),
// joint rates]; nq = nv + 1. Geared joints use motor angles qm = p q, their rotors exactly
// coupled or as armature (Gear).
#pragma once

#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "outputs.hpp"
#include "recorded_scalar.hpp"
#include "spatial_algebra.hpp"
#include "spatial_description.hpp"

namespace spacearm::spatial {

using spacearm::Dimensions;
using spacearm::Values;

// Defined in spatial_chain.cpp for double, Sym and their duals. The chain at one state over the
// scalar T (double, or recorded_scalar.hpp's Sym and Dual): its numbers come from Values (inputs
// "q" and "qd" by the registry's names, literals), so one definition serves the reference in double
// and the recorded programs. The members are those recursive_algorithms.hpp lists for a chain.
template <class T>
class Chain {
 public:
  // q has nq entries, v nv (the layout above). The quaternion must be of unit length.
  Chain(const ChainDescription& d, Values<T> values);

  static Dimensions dimensions(const ChainDescription& d) {
    return {d.nq(), d.nv(), static_cast<int>(d.links.size()), true, d.num_end_effectors()};
  }
  // Entry i of qdot = f(q, v): the base origin's velocity, the quaternion's rate
  // 1/2 q (0, omega) with omega in the base frame, the joint rates.
  static T configuration_rate(const ChainDescription& d, const Values<T>& values, int i);
  // The base origin's velocity (world frame), v's first three entries for a free base.
  static int base_translations(const ChainDescription& d) { return d.free_base ? 3 : 0; }
  // The base's turns (its angular velocity in its own frame), the next three for a free base,
  // and a world vector u's rate as the base turns about its axis k: (R e_k) x u.
  static int base_rotations(const ChainDescription& d) { return d.free_base ? 3 : 0; }
  std::vector<T> turned_about_base_axis(int k, const std::vector<T>& u) const;
  int nq() const { return d_.nq(); }
  int nv() const { return d_.nv(); }
  T input(const std::string& array, int i) const { return values_.input(array, i); }
  // Joint j's (1-based) torque tau enters as Q = tau / p on the coordinate it drives (its slot,
  // or a flexible joint's motor: ChainDescription::motor_coordinate).
  int torque_coordinate(int j) const { return motor_[j]; }
  T per_torque(int j) const {
    const Gear& g = d_.links[j - 1].gear;
    return g.present ? inverse(g.ratio) : num(1.0);
  }
  std::vector<T> mass_matrix() const;  // row-major nv x nv
  // Q = M vdot + b (recursive Newton-Euler; no gravity: a satellite in free fall).
  std::vector<T> inverse_dynamics(const std::vector<T>& vdot) const;
  T kinetic_energy() const;
  // qdd = M^-1 (Q - b) by the articulated-body algorithm, with the pivots D_i of M factored from
  // the tip inward (the base's last, in its own frame) and D_i / M_ii.
  std::vector<std::vector<T>> forward_dynamics(const std::vector<T>& Q) const;
  // The joints' friction on their motor coordinates' rates (Friction), nv; f enters as
  // M qdd + b + f = Q.
  std::vector<T> friction_forces() const;
  // The flexible joints' springs and dampers, dV/dq + dD/dqd (nv) with V = sum 1/2 k (qm/p - q)^2
  // and the Rayleigh function D = sum 1/2 d (qmd/p - qd)^2; they enter as M qdd + b + f = Q.
  std::vector<T> spring_damper_forces() const;
  T potential_energy() const;
  // Springs, dampers and friction.
  std::vector<T> passive_forces() const;
  // M v: the momentum conjugate to each velocity (recursive_algorithms.hpp's P = d(M v)/dq).
  std::vector<T> generalized_momentum() const;
  // The Hamel coupling of the quasi-velocities as a matrix H(M) (nv x nv, row-major) with
  // H v = [0, omega x (M v)_omega, 0]: the base's angular velocity is in its own frame, whose
  // directions do not commute (Euler's omega x L). Zero for a fixed base.
  std::vector<T> hamel_coupling(const std::vector<T>& M) const;
  // [P (3), L (3)]: linear momentum and angular momentum about the world origin, in the world.
  std::vector<T> momentum() const;
  // Each end effector's pose [x, y, z, w, qx, qy, qz], stacked: its world position and
  // orientation as a quaternion, composed joint by joint from the root (no branches:
  // recordable); it has the norm of the base's quaternion in q (1 for a unit one; a square root
  // is not recordable).
  std::vector<T> end_effector_pose() const;
  // The link-side joint angles and rates (N): a rigid gear's slot divided by its ratio (qm / p),
  // any other slot as it is.
  std::vector<T> joint_angles() const;
  std::vector<T> joint_rates() const;
  // The world positions of joints 1..N (each link frame's origin) and of the end effectors, for
  // drawing: row-major 3 x (N + E), one column per point.
  std::vector<T> joint_positions() const;
  // Each body's frame in the world (0 the base, i link i), for drawing its visuals: 12 numbers
  // per body, the position then the rotation row-major. Not a registry output.
  std::vector<T> body_frames() const;
  // The geometric Jacobians, stacked, row-major 6E x nv: each end effector's linear and angular
  // velocity in the world per unit velocity (zero in the columns of joints that do not carry it).
  std::vector<T> end_effector_jacobian() const;
  // Umetani and Yoshida's generalized Jacobian J* (6E x N): the end effectors' twists per unit
  // joint (motor) rate with the base moving so that the momentum stays zero. Free base only.
  std::vector<T> generalized_jacobian() const;
  // The joint torques tau = p Q that give the link-side joint accelerations qdd_joints with no
  // force on the free base, and the base's acceleration: {tau (N), qdd_base (6)}.
  std::vector<std::vector<T>> free_base_inverse_dynamics(const std::vector<T>& qdd_joints) const;

 private:
  const ChainDescription& d_;
  Values<T> values_;
  int n_ = 0;
  std::vector<int> parent_;      // the body that carries link i (parent_[0] unused)
  std::vector<Transform<T>> X_;  // parent -> link i (X_[0] unused)
  // X_[i]'s rotation as turns, R = E^T = turns_[i][0] turns_[i][1] ... (the origin's yaw, pitch
  // and roll, then the joint's own turn, always last), for the inertias' transforms.
  std::vector<std::vector<Turn<T>>> turns_;
  // X_[i]'s shift alone, (1, r): applied after the turns.
  Transform<T> shift(int i) const {
    return {num(Mat3<double>{1, 0, 0, 0, 1, 0, 0, 0, 1}), X_[i].r};
  }
  std::vector<RigidInertia<T>> I_;  // each body's, about its origin, in its frame
  std::vector<Motion<T>> V_;        // each body's velocity, in its frame
  std::vector<Vec3<T>> parent_w_;   // the parent's angular velocity, in link i's frame
  std::vector<Vec3<T>> p_;          // world positions of the body origins
  std::vector<Mat3<T>> R_;          // world orientations
  std::vector<Vec3<T>> axis_;       // each joint's unit axis, in its link's frame
  std::vector<T> qd_;               // joint (or motor) rates (qd_[0] unused)
  // Per joint: the velocity index its torque drives (ChainDescription::motor_coordinate) and that
  // coordinate's rate, at which its rotor turns relative to the parent.
  std::vector<int> motor_;
  std::vector<T> motor_qd_;
  // Per joint: the link's motion per unit rate (a / p, 0), and an exactly coupled rotor's
  // transform from the parent (the joint's origin, not turned), inertia and velocity.
  std::vector<Motion<T>> S_;
  std::vector<Transform<T>> rotor_X_;
  std::vector<RigidInertia<T>> rotor_I_;
  std::vector<Motion<T>> rotor_V_;
  // Whether joint i has an exactly coupled rotor (a body on the parent), and whether it is
  // flexible (its rotor on a coordinate of its own, a leaf of the tree).
  // A coupling factor c splits the rotor (spatial_description.hpp's Gear) into an exact rotor of
  // inertia c I_r, armature (1 - c) J and a rotational inertia (c^2 - c) I_r on the parent:
  // together 1/2 (c omega' + qd_m a)^T I_r (c omega' + qd_m a), in the same algorithms.
  bool exact_rotor(int i) const {
    const Gear& g = d_.links[i - 1].gear;
    return g.present && (g.exact || g.coupled);
  }
  bool coupled(int i) const { return d_.links[i - 1].gear.present && d_.links[i - 1].gear.coupled; }
  T coupling(int i) const { return value(d_.links[i - 1].gear.coupling); }
  bool flexible(int i) const {
    return d_.links[i - 1].gear.present && d_.links[i - 1].gear.flexible;
  }
  // A rigid gear: its ratio scales joint i's slot (qm = p q), its rotor turns on that slot.
  const Gear* slot_gear(int i) const {
    const Gear& g = d_.links[i - 1].gear;
    return g.present && !g.flexible ? &g : nullptr;
  }
  // A number of the description: the literal, or the run-time parameter params[q.index].
  T value(const Quantity& q) const {
    return q.is_parameter() ? values_.input("params", q.index) : num(q.value);
  }
  // 1 / value(q): one number for a literal.
  T inverse(const Quantity& q) const {
    return q.is_parameter() ? num(1.0) / value(q) : num(1 / q.value);
  }
  T ratio(int i) const {  // joint i's slot's ratio (1 without a rigid gear)
    const Gear* g = slot_gear(i);
    return g ? value(g->ratio) : num(1.0);
  }
  // k / p_i^power, power 1 or 2 (a literal ratio's folded to one number), for the slot.
  T over_ratio(int i, double k, int power = 1) const {
    const Gear* g = slot_gear(i);
    if (!g) return num(k);
    if (!g->ratio.is_parameter())
      return num(power == 1 ? k / g->ratio.value : k / (g->ratio.value * g->ratio.value));
    const T r = num(1.0) / ratio(i);
    return power == 1 ? r * k : r * r * k;
  }
  // The armature inertia on joint i's slot (0 without a rigid armature-coupled gear).
  T armature(int i) const {
    const Gear* g = slot_gear(i);
    if (g && g->coupled) return (num(1.0) - coupling(i)) * value(g->axial);
    return g && !g->exact ? value(g->axial) : T{};
  }
  // The armature inertia on a flexible joint's motor coordinate (0 otherwise).
  T motor_armature(int i) const {
    const Gear& g = d_.links[i - 1].gear;
    return flexible(i) && !g.exact ? axial(i) : T{};
  }
  // A flexible joint's spring deflection qm / p - q, from q (of nq) or its rate from v.
  T deflection(int i, const std::string& array) const;
  T axial(int i) const {  // the rotor's axial inertia
    const Gear& g = d_.links[i - 1].gear;
    return value(g.axial);
  }
  bool literal_ratio(int i) const {
    const Gear* g = slot_gear(i);
    return !g || !g->ratio.is_parameter();
  }
  double ratio_value(int i) const {  // a literal slot ratio
    const Gear* g = slot_gear(i);
    return g ? g->ratio.value : 1.0;
  }
  // p_i^power (1 or 2) times the rotor's axial inertia, one number where both are literals.
  T ratio_times_axial(int i, int power) const;
  // p^2 times the armature: joint i's armature per unit link rate.
  T armature_per_link_rate(int i) const {
    const Gear* g = slot_gear(i);
    if (g && g->coupled) return (num(1.0) - coupling(i)) * ratio_times_axial(i, 2);
    return g && !g->exact ? ratio_times_axial(i, 2) : T{};
  }
  // The exact rotor's share of p_i^power J (all of it, or c of it with a coupling factor).
  T rotor_ratio_times_axial(int i, int power) const {
    return coupled(i) ? coupling(i) * ratio_times_axial(i, power) : ratio_times_axial(i, power);
  }
  Mat3<T> rotor_inertia(int i, const Vec3<double>& a) const;
  // A body's inertia about its frame's origin: its own inertial and its welded parts'.
  RigidInertia<T> body_inertia(const Link& l) const;
  RigidInertia<T> rigid_inertia(const Inertial& b) const;
  T num(double x) const { return values_.number(x); }
  Vec3<T> num(const std::array<double, 3>& x) const { return {num(x[0]), num(x[1]), num(x[2])}; }
  Mat3<T> num(const Mat3<double>& A) const;
  static Vec3<T> zero3() { return {T{}, T{}, T{}}; }
  static Motion<T> zero_motion() { return {zero3(), zero3()}; }
  Motion<T> base_unit(int k) const;  // the base's motion for a unit v_k (k < 6)
  std::vector<RigidInertia<T>> composite_inertias() const;
  // in_parent(X_[i], I), turn by turn: the cheaper form of the same transform.
  RigidInertia<T> in_parent_of(int i, const RigidInertia<T>& I) const;
  ArticulatedInertia<T> in_parent_of(int i, const ArticulatedInertia<T>& I) const;
  std::vector<Turn<T>> joint_turns(const Link& l, const Vec3<double>& a, const T& c,
                                   const T& s) const;
  std::vector<T> mass_matrix_diagonal() const;
  void add_rotor(int i, ArticulatedInertia<T>& Ia, Force<T>& U, T& D, Force<T>& pa) const;
  // An exact rotor's velocity-product force along what is left of it once its own coordinate is
  // eliminated, in link i's frame: (omega' x a) ((J - t) a . omega' + J qd_m).
  Vec3<T> rotor_bias(int i) const;
  // A flexible joint's exact rotor, a leaf on the parent: what it passes to the parent in link
  // i's frame once its coordinate (net force Q_m) is eliminated.
  void add_leaf_rotor(int i, const T& Q_m, ArticulatedInertia<T>& reduced, Force<T>& pa) const;
  // Column `col` of M above joint i: the force `up` (in its parent's frame) read along the joints
  // from that parent to the root and the base's directions, carried inward; the entries of
  // joints on other branches stay zero (RBDA 6.5's branch-induced sparsity).
  void fill_column(std::vector<T>& M, int col, int i, Force<T> up) const;
  // Body b's contribution: the bodies that carry mass (a fixed base carries none that moves).
  int first_body() const { return d_.free_base ? 0 : 1; }
  // The links from the root to body b, root first (empty for the base).
  std::vector<int> path_to(int b) const;
  // End effector e's origin in the world.
  Vec3<T> end_effector_point(int e) const;
};

}  // namespace spacearm::spatial
