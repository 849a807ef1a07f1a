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

namespace spacearm {

// Thrown for any malformed or physically invalid scene; the message names the file,
// the field and the offending value.
class SceneError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A scalar of the scene: either a literal number (kept as its exact decimal text so the
// generator can fold it as an exact rational) or a reference to a named run-time parameter.
struct Quantity {
  std::string parameter;  // non-empty: a run-time parameter of this name
  std::string literal;    // decimal text of the number, e.g. "0.181" or "1e-5"
  double value = 0.0;     // the literal's value, or the parameter's nominal value

  bool is_parameter() const { return !parameter.empty(); }
};

struct Parameter {
  std::string name;
  Quantity nominal;  // always a literal: used for self-checks and as a default at run time
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
};

struct Scene {
  std::string name;         // C++ namespace of the emitted model
  std::string source_path;  // as given on the command line
  std::string content;      // raw file text (hashed into the banner)
  std::string description;  // optional free text
  Base base;
  std::vector<Link> links;
  std::vector<Gear> gears;  // empty: reference model; else one per link (geared model)
  std::vector<Parameter> parameters;
  std::set<Output> outputs;

  bool free_floating() const { return base.type == BaseType::free_floating; }
  bool geared() const { return !gears.empty(); }
  int num_links() const { return static_cast<int>(links.size()); }
  // The one place that names the sizes: configuration nq (x0, y0, q0 of a free base, then one
  // angle per joint) and velocity nv (their rates: nv == nq for every planar chain; a base with
  // a quaternion would make them differ). Everything downstream reads Dimensions.
  int num_coordinates() const { return (free_floating() ? 3 : 0) + num_links(); }
  int num_velocities() const { return (free_floating() ? 3 : 0) + num_links(); }
  bool wants(Output o) const { return outputs.count(o) != 0; }
  // Names of the generalized coordinates, in order: x0 y0 q0 (free base), then q1..qN
  // (reference) or qm1..qmN (geared, motor angles; paper eq. 12).
  std::vector<std::string> coordinate_names() const;
};

// Largest number of links a scene may have; beyond it the closed-form expressions grow
// too large to generate in interactive time.
constexpr int kMaxLinks = 30;

Scene parse_scene(const std::string& yaml_text, const std::string& source_name);
Scene load_scene(const std::string& path);

// Stable 64-bit FNV-1a hash as 16 hex digits. Hand-written because it must be identical on
// every platform and standard library (std::hash is not) and needs no extra dependency.
std::string content_hash(const std::string& text);

}  // namespace spacearm
