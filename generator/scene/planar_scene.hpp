// Scene: the plain, validated description of a planar free-floating (or fixed-base)
// manipulator, read from a YAML file. No symbolic algebra here: the symbolic model is
// built from a Scene by symbolic_model.hpp.
#pragma once

#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "outputs.hpp"
#include "quantity.hpp"

namespace spacearm {

// Thrown for any malformed or physically invalid scene; the message names the file,
// the field and the offending value.
class SceneError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class BaseType { free_floating, fixed };

struct Base {
  BaseType type = BaseType::free_floating;
  Quantity mass;      // m0 [kg]
  Quantity inertia;   // I0 [kg m^2] about the base CoM
  Quantity mount[2];  // joint 1 position in the base frame [m]
};

struct Link {
  Quantity mass;     // m_i [kg]
  Quantity inertia;  // I_i [kg m^2] about the link CoM
  Quantity length;   // joint i to joint i+1 along the link's x axis [m]
  Quantity com[2];   // CoM in the link frame [m]
};

// One motor per joint, driving the link through a gear: qd_m = p qd (paper eq. 9).
struct Gear {
  Quantity ratio;          // p_i > 0
  Quantity motor_inertia;  // I_m_i >= 0 [kg m^2]
  // Reduce the link inertia by I_m so that p = 1 reproduces the reference model exactly.
  bool compensate_link_inertia = true;
  // rotor_coupling: exact (default) gives the motor 1/2 I_m (Omega_prev + qd_m)^2 (eqs. 10,
  // 11); armature keeps only 1/2 I_m qd_m^2, i.e. the reflected inertia I_m p^2 on the
  // joint's diagonal as MuJoCo, Drake and Pinocchio model it, without the coupling to the
  // previous body's rotation.
  bool armature = false;
  // rotor_coupling: PARAMETER (or a number in [0, 1]): the motor turns with c times the
  // previous body, 1/2 I_m (c Omega_prev + qd_m)^2: c = 1 is exact, c = 0 armature, so one
  // scene compares both at run time. Closed form only.
  std::optional<Quantity> coupling;
  // A flexible joint (Spong's model): a torsional spring of stiffness k [N m/rad] and an
  // optional damper d [N m s/rad] between the gear's output qm/p and the link angle q, both on
  // the link side. The joint then has two coordinates, q and qm (Scene::coordinate_names).
  std::optional<Quantity> stiffness, damping;
  bool flexible() const { return stiffness.has_value(); }
};

// Joint friction on the motor rate w (qd_m of a geared joint, qd of an ungeared one), opposing
// motion: f(w) = b w + Fc tanh(w/vs) + (Fs - Fc) exp(-(w/vst)^2) tanh(w/vs). A field not given
// is 0, except stribeck_static, which defaults to Fc (no Stribeck hump).
struct Friction {
  Quantity viscous, coulomb, velocity_scale, stribeck_static, stribeck_velocity;
  bool has_coulomb = false, has_stribeck = false;  // terms present (given and not literal 0)
};

// How M, the bias and the dynamics built on them are derived: closed (the Lagrangian's closed
// form, eq. 6 and 7: inspectable entries), recursive (RNEA, CRBA and ABA recorded as straight-line
// code: O(N)), or automatic (per function the cheaper in operations where the closed form is
// affordable, N <= kClosedFormLinks; recursive beyond).
enum class Formulation { automatic, closed, recursive };
// A formulation as scene files spell it: "auto", "closed", "recursive".
const char* to_string(Formulation f);

// Largest N at which `automatic` derives the closed form as well (it takes about a second there
// and grows much faster than N; the recursive form is the cheaper beyond it).
constexpr int kClosedFormLinks = 8;
// Largest N a scene may ask the closed form for (formulation: closed). Its derivation doubles
// about every two links (measured: 16 s and 92 MB at 12 links, over 2 min and 1 GB at 20).
constexpr int kMaxClosedFormLinks = 12;

// Smallest friction velocity (velocity_scale, stribeck_velocity) [rad/s]: below it tanh(w/vs)
// is a step that no integrator follows and the symbolic check point overflows.
constexpr double kMinFrictionVelocity = 1e-9;

struct Scene {
  std::string name;         // C++ namespace of the emitted model
  std::string source_path;  // as given on the command line
  std::string content;      // raw file text (hashed into the banner)
  std::string description;  // optional free text
  Base base;
  std::vector<Link> links;
  // Empty: the reference model; else one entry per link, empty for a joint without a gear.
  std::vector<std::optional<Gear>> gears;
  // Empty: no friction; else one entry per link, empty for a joint without friction.
  std::vector<std::optional<Friction>> friction;
  std::vector<Parameter> parameters;
  std::set<Output> outputs;
  std::set<Output> lanes;  // `lanes:` outputs also given for four states per call (ModelFacts)
  Formulation formulation = Formulation::automatic;

  // Whether the generator derives the closed forms of M and b, and tries the recursive ones.
  bool tries_closed_form() const {
    return formulation == Formulation::closed ||
           (formulation == Formulation::automatic && num_links() <= kClosedFormLinks);
  }
  bool tries_recursive() const { return formulation != Formulation::closed; }
  // Whether every closed form can be expanded in reasonable time (what `inspect` prints).
  bool closed_form_affordable() const {
    return formulation == Formulation::closed || num_links() <= kClosedFormLinks;
  }
  bool free_floating() const { return base.type == BaseType::free_floating; }
  bool geared() const;                // any joint has a gear
  bool has_gear(int joint) const;     // joint 0..N-1
  bool is_flexible(int joint) const;  // has a gear with a stiffness
  int num_flexible() const;           // joints with a spring
  bool has_friction() const;          // any joint has friction
  int num_links() const { return static_cast<int>(links.size()); }
  int num_base() const { return free_floating() ? 3 : 0; }
  // The one place that names the sizes: configuration nq (x0, y0, q0 of a free base, one
  // angle per joint, then the motor angle of each flexible joint) and velocity nv (their
  // rates: nv == nq for every planar chain; a base with a quaternion would make them differ).
  // Everything downstream reads Dimensions.
  int num_coordinates() const { return num_base() + num_links() + num_flexible(); }
  int num_velocities() const { return num_base() + num_links() + num_flexible(); }
  Dimensions dimensions() const { return {num_coordinates(), num_velocities(), num_links()}; }
  // Coordinate of joint j's own slot (its link angle, or the motor angle of a rigid gear) and
  // of its motor: the one that the joint torque drives (as tau / p, eq. 14) and friction
  // brakes. They differ only for a flexible joint, whose motor angle follows all joint slots.
  int joint_coordinate(int joint) const { return num_base() + joint; }
  int motor_coordinate(int joint) const;
  // What the scene has, as needs:: bits (outputs.hpp).
  unsigned features() const;
  bool wants(Output o) const { return outputs.count(o) != 0; }
  // Names of the generalized coordinates, in order: x0 y0 q0 (free base); per joint q_i
  // (no gear, or a flexible joint) or qm_i (a rigid gear: motor angle, paper eq. 12); then
  // qm_i of each flexible joint.
  std::vector<std::string> coordinate_names() const;
};

// Largest number of links a scene may have; beyond it the closed-form expressions grow
// too large to generate in interactive time.
constexpr int kMaxLinks = 30;

Scene parse_scene(const std::string& yaml_text, const std::string& source_name);
Scene load_scene(const std::string& path);
// A scene file's text (at most 1 MB), or a SceneError naming the file.
std::string read_scene_file(const std::string& path);

// Stable 64-bit FNV-1a hash as 16 hex digits. Hand-written because it must be identical on
// every platform and standard library (std::hash is not) and needs no extra dependency.
std::string content_hash(const std::string& text);

}  // namespace spacearm
