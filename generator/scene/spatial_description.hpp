// What a spatial arm is made of, as the scene readers give it to the derivation: a free (or
// fixed) base and a tree of revolute joints (a serial chain the common case), each number a
// literal or a run-time parameter (spatial_scene.hpp, urdf_reader.hpp read it; spatial_chain.hpp
// derives from it). Plain data and the frames of welded parts: no algorithm, no GiNaC.
#pragma once

#include <algorithm>
#include <array>
#include <string>
#include <vector>

#include "quantity.hpp"
#include "spatial_algebra.hpp"

namespace spacearm::spatial {

// A number of the model may be a run-time parameter (quantity.hpp): the chain reads the
// parameter, never its nominal value.
using spacearm::kLiteral;
using spacearm::Quantity;

// A joint's gear: a motor whose rotor turns at p times the joint's rate relative to the parent
// link, so the joint's coordinate is the motor angle qm = p q (eq. 12 in the plane) and its
// generalized force tau / p. The rotor is a body of revolution about the joint axis through
// the joint's origin (its mass belongs to the parent link's inertial). Exact coupling carries
// it on the parent, turning at omega_parent + qd_m a (its gyroscopic torques and angular
// momentum included); armature keeps only the axial inertia on the motor coordinate (MuJoCo's,
// Drake's and Pinocchio's model).
// A flexible joint (Spong's model, as in the plane) has a torsional spring of stiffness k and a
// damper d between the gear's output qm / p and the link angle q: its slot then holds q, and the
// motor angle qm a coordinate of its own after all the joints (ChainDescription::motor_coordinate).
// rotor_coupling: c in [0, 1] (coupled; a number or a run-time parameter) gives the rotor
// 1/2 (c omega_parent + qd_m a)^T I_r (c omega_parent + qd_m a): 1 is exact, 0 armature, so one
// compiled model compares both (as in the plane). Rigid gears only.
struct Gear {
  bool present = false;
  Quantity ratio = 1;
  Quantity axial = 0, transverse = 0;  // the rotor's inertia about its axis and across it
  bool exact = true;
  bool coupled = false;  // coupling holds the factor c (exact is then unused)
  Quantity coupling = 1;
  bool flexible = false, has_damping = false;
  Quantity stiffness = 0, damping = 0;
};

// Friction on a joint's coordinate rate w (the motor's, qd_m, for a geared joint), opposing
// motion, as in the plane (planar_scene.hpp's Friction): f(w) = b w + Fc tanh(w/vs)
// + (Fs - Fc) exp(-(w/vst)^2) tanh(w/vs). Each value a literal or a run-time parameter.
struct Friction {
  bool present = false;
  Quantity viscous = 0, coulomb = 0, velocity_scale = 1, stribeck_static = 0, stribeck_velocity = 1;
  bool has_coulomb = false, has_stribeck = false;  // terms present (a parameter, or not 0)
};

// A body's mass, centre of mass and inertia about it (ixx, ixy, ixz, iyy, iyz, izz), in its
// frame, each a literal or a run-time parameter.
struct Inertial {
  Quantity mass = 0;
  std::array<Quantity, 3> com{};
  std::array<Quantity, 6> inertia{};
  bool uses_parameter() const {
    auto parameter = [](const Quantity& q) { return q.is_parameter(); };
    return mass.is_parameter() || std::any_of(com.begin(), com.end(), parameter) ||
           std::any_of(inertia.begin(), inertia.end(), parameter);
  }
  std::array<double, 3> com_values() const { return {com[0].value, com[1].value, com[2].value}; }
  std::array<double, 6> inertia_values() const {
    std::array<double, 6> v;
    for (int k = 0; k < 6; ++k) v[k] = inertia[k].value;
    return v;
  }
};

// A body welded to a link at a fixed frame (its origin xyz and rpy in the link's frame): a
// URDF link whose inertial a scene gives (a parameter cannot be lumped in numbers).
struct Part {
  std::array<double, 3> xyz{}, rpy{};
  Inertial inertial;
};

// One link and the revolute joint that carries it (URDF's joint origin and axis; the link's
// inertial about its centre of mass, in the link frame), with the parts welded to it.
// parent: the body the joint leaves (0 the base, k link k, k before this link: Featherstone's
// parent array, RBDA 4.1); -1, the default, is the link before it (a serial chain).
struct Link : Inertial {
  int parent = -1;
  std::array<double, 3> origin_xyz{}, origin_rpy{};  // the joint frame in the parent link's
  std::array<double, 3> axis{1, 0, 0};               // unit, in the joint frame
  std::vector<Part> parts;
  Gear gear;
  Friction friction;
};

// A frame fixed in a body whose pose and velocity the model gives (a tool, a URDF link welded to
// the body): its origin and rpy in the body's frame, named by its link ("" for a chain's one).
struct EndEffector {
  std::string link;
  int body = -1;  // 0 the base, i link i; -1: the last link
  std::array<double, 3> xyz{}, rpy{};
};

// The base (the root link, the satellite) and the links after it, numbered depth-first from the
// root (each link's parent before it); a serial chain has each the child of the one before.
struct ChainDescription {
  bool free_base = true;
  Link base;  // its mass, com and inertia; its origin and axis are unused
  std::vector<Link> links;
  // In the order of the outputs' blocks (pose 7 each, Jacobian rows 6 each); one at the last
  // link's origin unless a reader says otherwise.
  std::vector<EndEffector> end_effectors{EndEffector{}};
  // snap_right_angles: the rpy angles that are multiples of pi/2 turn by exact cosines and sines.
  bool exact_right_angles = false;
  int num_base() const { return free_base ? 6 : 0; }
  // The body that carries link i (1-based): 0 the base, else a link before i.
  int parent(int i) const {
    const int p = links.at(i - 1).parent;
    return p < 0 ? i - 1 : p;
  }
  bool serial() const {
    for (int i = 1; i <= static_cast<int>(links.size()); ++i)
      if (parent(i) != i - 1) return false;
    return true;
  }
  int num_end_effectors() const { return static_cast<int>(end_effectors.size()); }
  // End effector e's name: its link's, or end_effector_<e + 1> (a chain's tool, unnamed).
  std::string end_effector_name(int e) const {
    const std::string& link = end_effectors.at(e).link;
    return link.empty() ? "end_effector_" + std::to_string(e + 1) : link;
  }
  // The body end effector e sits on.
  int end_effector_body(int e) const {
    const int b = end_effectors.at(e).body;
    return b < 0 ? static_cast<int>(links.size()) : b;
  }
  // The one place that lays out the velocities: the base's, one slot per joint (its link angle's
  // rate, or a rigid gear's motor rate), then the motor of each flexible joint; nq = nv + 1 with
  // a free base's quaternion.
  int num_flexible() const {
    int count = 0;
    for (const Link& l : links) count += l.gear.present && l.gear.flexible;
    return count;
  }
  int nv() const { return num_base() + static_cast<int>(links.size()) + num_flexible(); }
  int nq() const { return nv() + (free_base ? 1 : 0); }
  // The velocity index of joint j's slot (0-based j) and of the coordinate its torque drives
  // (as tau / p) and friction brakes: the slot, or a flexible joint's motor coordinate.
  int joint_coordinate(int j) const { return num_base() + j; }
  int motor_coordinate(int j) const {
    const Gear& g = links.at(j).gear;
    if (!(g.present && g.flexible)) return joint_coordinate(j);
    int before = 0;
    for (int k = 0; k < j; ++k) before += links[k].gear.present && links[k].gear.flexible;
    return num_base() + static_cast<int>(links.size()) + before;
  }
  // The index in q of velocity index v (past a free base's quaternion: v + 1).
  int q_index(int v) const { return free_base && v >= 6 ? v + 1 : v; }
};

// A URDF joint's <limit> and <dynamics>, on the link side: effort [N m] and velocity [rad/s]
// (0 or absent: none given, as URDFs write placeholders), a revolute joint's range lower..upper
// [rad] (both 0 or absent, or a continuous joint: none), and damping [N m s/rad] and friction
// [N m]. Not part of the model: plans and runs are measured against the limits, a point-to-point
// plan keeps them, and the scene's `friction: {from_urdf: true}` turns the dynamics into joint
// friction.
struct JointLimits {
  double effort = 0, velocity = 0;
  double lower = 0, upper = 0;
  double damping = 0, friction = 0;
  bool has_effort() const { return effort > 0; }
  bool has_velocity() const { return velocity > 0; }
  bool has_range() const { return lower < upper; }
};

// A URDF <visual> shape of a body (its link or a link welded to it), in the body's frame, for
// the viewer: a box (size x y z), a cylinder along its z (radius, length), a sphere (radius), or
// an STL mesh (a file in the URDF's folder, scaled per axis); at xyz, turned by the quaternion
// (w, x, y, z). Not part of the model.
struct Visual {
  std::string kind;              // "box", "cylinder", "sphere" or "mesh"
  std::array<double, 3> size{};  // box: x y z; cylinder: radius, length, 0; sphere: radius, 0, 0;
                                 // mesh: the scale
  std::array<double, 3> xyz{};
  std::array<double, 4> quaternion{1, 0, 0, 0};
  std::string mesh;  // a mesh's path relative to the URDF's folder (no '..', not absolute)
};

// A part's frame as the transform from the link's frame to the part's.
inline Transform<double> part_frame(const Part& p, bool exact_right_angles = false) {
  return {transposed(rpy_rotation(p.rpy, exact_right_angles)), {p.xyz[0], p.xyz[1], p.xyz[2]}};
}

}  // namespace spacearm::spatial
