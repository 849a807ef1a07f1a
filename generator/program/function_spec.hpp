// What lowering hands to the printer: each emitted function as named, shaped arrays and the
// straight-line program of its results, plus the facts of the model the generated header
// states. No GiNaC, no bodies, angles or gears: the printer turns this into C++.
#pragma once

#include <string>
#include <vector>

#include "outputs.hpp"
#include "straight_line.hpp"
#include "value_span.hpp"

namespace spacearm {

// An input or result array of an emitted function.
struct ArraySpec {
  std::string name;  // argument name: "q", "M"
  Size rows = Size::one, cols = Size::one;
  bool symmetric = false;  // results: the lower triangle is printed as a copy of the upper
};

struct FunctionSpec {
  std::string name;
  std::string doc;                 // one line
  std::string equation;            // the paper's equation number, or empty
  std::vector<ArraySpec> inputs;   // the run-time parameters `params` always follow
  std::vector<ArraySpec> results;  // a single 1 x 1 result is returned by value
  Program program;
  // Per result, its entries row by row (all of them; a symmetric result repeats the upper
  // triangle's roots below the diagonal).
  std::vector<std::vector<SRef>> entries;
  std::string variant;  // the lowering variant kept, e.g. the velocity basis "qd" or "omega"
  // How its results were derived: "closed form" or "recursive (ABA)", ... (planar_scene.hpp).
  std::string formulation;
  bool plain = false;               // the benchmark baseline: every expression printed inline
  bool model_constant = false;      // a constant of the model (the gear ratios): no formulation
  bool lanes = false;               // the C interface has a 4-lane version too (spacearm_<name>_x4)
  std::vector<SRef> roots() const;  // every entry, each once
};

// A condition on the run-time parameters that the scene parser checks for literals: value > 0
// (or >= 0), else `message`. Values are roots of ModelFacts::checks_program.
struct ParameterCheck {
  SRef value;
  bool strict = true;
  std::string message;  // fixed text built from field names, never user text
};

// The model as the generated header describes it.
struct ModelFacts {
  std::string name;         // namespace spacearm::models::<name>
  std::string description;  // user text: printed only through comment_lines()
  std::string coordinates_note;
  Dimensions dims;
  bool free_floating = false, geared = false;
  // The base's velocities (0 for a fixed base) and where a quaternion sits in q (-1: none; the
  // planar models have none, so nq = nv).
  int num_base = 0, quaternion_offset = -1;
  std::vector<std::string> coordinate_names, parameter_names;
  // Each end effector's name (a tree's by their links, untrusted text), dims.num_end_effectors.
  std::vector<std::string> end_effector_names;
  // A tree's joints (empty for a serial chain with one end effector), depth-first from the
  // root: each one's name (a
  // URDF's, else jointK) and the body it leaves (0 the base, k joint k's link).
  std::vector<std::string> joint_names;
  std::vector<int> joint_parents;
  std::vector<int> end_effector_bodies;  // each end effector's (0 the base, k joint k's link)
  std::vector<double> nominal_parameters;
  std::string scene_hash;   // "fnv1a64:..."
  std::string formulation;  // the scene's: "auto", "closed" or "recursive"
  // A spatial arm's bodies' inertias as the scene checked them: "physical" or "positive_definite"
  // (identified tensors as given); empty for a planar model.
  std::string inertia_check;
  bool right_angles_snapped = false;  // a spatial scene's snap_right_angles
  std::vector<Output> outputs;
  // Outputs whose C interface also takes four states per call besides has_lanes_version's (the
  // scene's `lanes:`): each costs compile time (space_arm7's state Jacobian 2.4-3x), so a scene
  // asks.
  std::vector<Output> lanes;
  unsigned features = 0;  // needs:: bits of the scene (outputs.hpp)
  // Springs, dampers or friction act besides M qdd + b.
  bool has_passive_forces() const { return spacearm::has_passive_forces(features); }
  // Velocity index that joint torque tau_i drives (as tau_i / p_i, eq. 14), where it is not
  // the joint's own slot (a flexible joint's motor); empty: the joint slots, nv - N .. nv - 1.
  std::vector<int> actuated_coordinates;
  // Per joint: its slot in q holds the motor angle qm = p q (a rigid gear, eq. 12), not the link
  // angle q (no gear, or a flexible joint, whose motor angle has a coordinate of its own).
  std::vector<bool> motor_angle_slots;
  Program checks_program;  // inputs: params(i)
  std::vector<ParameterCheck> checks;
  // The numbers whose span a failure names (value_span.hpp); the library lists them.
  std::vector<SpanField> span_fields;
};

// Per joint, the velocity index its torque drives (as tau_i / p_i, eq. 14): the joint's own slot,
// or a flexible joint's motor coordinate.
inline std::vector<int> actuated_coordinates(const ModelFacts& facts) {
  if (!facts.actuated_coordinates.empty()) return facts.actuated_coordinates;
  std::vector<int> slots;
  for (int j = 0; j < facts.dims.num_links; ++j) slots.push_back(facts.num_base + j);
  return slots;
}

struct LoweredModel {
  ModelFacts facts;
  std::vector<FunctionSpec> functions;
};

}  // namespace spacearm
