// The output registry: the one list of what a model can emit. Every stage reads it: scene
// validation (`outputs:`), derivation, lowering, the printer's C interface, `eval`,
// `inspect`, the compile-and-load path and the runtime (through the kHas_ flags of the
// generated header). Adding an output is one entry in outputs.cpp plus its derivation
// (symbolic_model.cpp) or its composition from other outputs (planar_lowering.cpp).
// No GiNaC and no Eigen here: this header is plain data.
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace spacearm {

enum class Output {
  mass_matrix,
  coriolis_matrix,
  bias_forces,
  kinetic_energy,
  momentum,
  end_effector_pose,
  end_effector_jacobian,
  joint_positions,
  joint_angles,
  joint_rates,
  mass_matrix_derivative,
  christoffel_coriolis_matrix,
  inverse_dynamics,
  forward_dynamics,
  generalized_jacobian,
  free_base_inverse_dynamics,
  potential_energy,
  spring_damper_forces,
  friction_forces,
  forward_dynamics_derivatives,
};

// What a scene must have for an output to be defined (OutputInfo::needs, a bit mask;
// Scene::features() says what a scene has).
namespace needs {
constexpr unsigned nothing = 0;
constexpr unsigned free_base = 1;     // a free_floating base (momentum, base elimination)
constexpr unsigned rigid_joints = 2;  // no flexible joint (the joint rows are the only joint state)
constexpr unsigned springs = 4;       // a flexible joint (gears[i].stiffness)
constexpr unsigned friction = 8;      // a `friction:` entry
}  // namespace needs
// Springs, dampers or friction act besides M qdd + b (needs:: bits of a scene).
inline bool has_passive_forces(unsigned features) {
  return (features & (needs::springs | needs::friction)) != 0;
}
// Forward dynamics is available: emitted, or solved from M and b where nothing acts besides
// them. has(o): whether the model emits output o.
template <class Has>
bool has_forward_dynamics(const Has& has, bool passive_forces) {
  return has(Output::forward_dynamics) ||
         (has(Output::mass_matrix) && has(Output::bias_forces) && !passive_forces);
}
// Why a scene with `features` cannot have an output that needs `required`, e.g. "is only
// defined for a free_floating base"; empty when it can.
std::string missing_feature(unsigned required, unsigned features);

// A size of the model: the shape of an input or a result. pose, twist and point depend on the
// space the model moves in: a pose [x, y, phi] (3) or [position, quaternion w x y z] (7), a
// twist, wrench or momentum (3 or 6), a point (2 or 3). poses and twists: one per end effector,
// stacked; num_points: the joints' and the end effectors' points.
enum class Size {
  one,
  nq,
  nv,
  num_links,
  num_links_plus_one,
  num_base,
  pose,
  twist,
  point,
  poses,
  twists,
  num_points
};

// The model's sizes, in one place: nq coordinates, nv velocities (equal for every planar
// model so far, kept apart for a quaternion base), num_links joints, and the space.
struct Dimensions {
  int nq = 0, nv = 0, num_links = 0;
  bool spatial = false;          // 3D (pose 7, twist 6, point 3); else the plane
  int num_end_effectors = 1;     // a tree's may be several (each a pose and 6 Jacobian rows)
  int operator()(Size s) const;  // num_base: the velocities of the base, nv - num_links
};
// The name of a size in generated code ("kNv", "3").
std::string size_constant(Size s, const Dimensions& dims);

// Inputs of emitted functions besides the run-time parameters, in a fixed order.
enum class Input { q, qd, qdd, generalized_forces, joint_accelerations };
struct InputInfo {
  Input id;
  const char* name;  // argument name in generated code and in messages
  Size size;
};
const InputInfo& info(Input input);

// One result array of an output's function.
struct ResultInfo {
  const char* name;  // argument name in generated code ("M")
  Size rows, cols;
  bool symmetric;  // only the upper triangle is computed; the lower one is a copy
};

struct OutputInfo {
  Output id;
  const char* name;    // the scene's `outputs:` key, the function name, the eval JSON key
  const char* symbol;  // short name of its entries for `inspect` ("M" as in M[1][2])
  std::vector<Input> inputs;
  std::vector<ResultInfo> results;  // the first one is the output's value
  unsigned needs;                   // needs::..., what the scene must have
  bool by_default;  // emitted when a scene lists no outputs (and it has what the output needs)
  // Empty: a closed form derived symbolically (inspect shows its entries). Else composed in
  // the straight-line program from these outputs' closed forms (a solve, a product).
  std::vector<Output> composed_of;
  const char* equation;  // the paper's equation, or "" (none there)
  const char* doc;       // one line, shown in generated code and --help
};

// Every output, in emission order.
const std::vector<OutputInfo>& output_registry();
const OutputInfo& info(Output output);
std::string to_string(Output output);
// Whether a scene that lists no outputs gets `o`. Without closed forms (past 8 planar links, and
// every spatial arm) C leaves the defaults: its recursive program (N^2 entries, eq. 7) doubles
// the first compile (planar N = 30: 12.6 s with it; space_arm7: 4.4 s with it, 2.2 s without).
// It stays available by name.
bool emitted_by_default(const OutputInfo& o, bool closed_form_affordable);
std::optional<Output> output_from_string(const std::string& name);
// Whether the C interface also exports the output for four states per call (spacearm_<name>_x4):
// what a sweep and a batched simulation evaluate at every step. Only these: a 4-lane version
// doubles a function's compile time (chain_n30's library 1.7 s to 4.8 s with every output's).
bool has_lanes_version(Output output);
// A scene's `lanes:` entry that is no output the scene emits: why, for the reader's message.
std::string lanes_error(const std::string& name, bool known);
// The bit of an output in the masks the C interface and the loader exchange.
inline unsigned long output_bit(Output o) { return 1ul << static_cast<unsigned>(o); }
// The bits of a set or list of outputs (what a compiled library reports it emits).
template <class Outputs>
unsigned long output_mask(const Outputs& outputs) {
  unsigned long mask = 0;
  for (Output o : outputs) mask |= output_bit(o);
  return mask;
}
// "mass_matrix, coriolis_matrix, ..." for messages.
std::string output_names();

// The function that gives M and b in one call (sharing their sin/cos and common terms), emitted
// beside them wherever a model has both; what forward dynamics needs.
inline constexpr const char* kMassMatrixAndBias = "mass_matrix_and_bias";

// An entry "NAME", "NAME[i]" or "NAME[i][j]" as inspect takes it (NAME a registry symbol, spaces
// allowed around the parts); std::invalid_argument naming the entry if malformed.
struct EntryText {
  std::string name;
  std::vector<int> indices;
};
EntryText parse_entry(const std::string& entry);
// The (row, column) entry e names in output o's first result, rows x cols: a scalar takes no
// index, a vector one, a matrix two (by the registry's shape, so that a one-coordinate model's M
// still takes two); each in range, else std::invalid_argument after `shown` ("entry 'M[9]'").
std::pair<int, int> entry_position(const EntryText& e, const OutputInfo& o, int rows, int cols,
                                   const std::string& shown);

}  // namespace spacearm
