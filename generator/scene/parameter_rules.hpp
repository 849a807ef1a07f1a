// The range rules on a scene's quantities, one kind of rule for both kinds of scene: positive
// masses, inertias, lengths, ratios and stiffnesses, non-negative motor inertias, dampers and
// friction, a compensated link inertia above its motor's, a coupling factor in [0, 1], friction
// velocities of at least 1e-9, a spatial body's physical inertia tensor. The scene's validation
// checks them for the literal (and nominal) values and names the field; the generated
// parameter_error() checks the same rules again for run-time parameter values
// (derive/parameter_checks.hpp prints those whose value depends on a parameter).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "planar_scene.hpp"

namespace spacearm {

// One term of a rule's value: coefficient * quantity, or the constant `coefficient` alone.
struct RangeTerm {
  double coefficient = 1;
  bool constant = false;
  Quantity quantity;
};

// What a spatial body's inertia tensor about its centre must be (a scene's `inertia_check`):
// physical, a rigid body's (positive definite, each principal moment at most the sum of the other
// two); or positive_definite, any symmetric positive definite tensor (identified parameters, such
// as a link tensor holding its motor's reflected inertia, often break the triangle inequality).
enum class InertiaRule { none, physical, positive_definite };

struct RangeRule {
  std::string field;             // the field an error names: "gears[0].ratio"
  std::string node_field;        // the field whose YAML node an error points at (empty: field)
  std::vector<RangeTerm> terms;  // value = the sum of the terms, in this order
  bool strict = true;            // value > 0; else value >= 0
  std::string message;           // at run time, fixed text: "gears[0].ratio must be positive"
  std::string literal_message;   // at parse time, with the values: "must be positive, got 0"
  bool at_parse = true;          // the scene checks it
  bool at_run_time = true;       // parameter_error() checks it (where it uses a parameter)
  // Not none: the terms are an inertia tensor's six entries (ixx, ixy, ixz, iyy, iyz, izz), which
  // must be physical or positive definite (the spatial reader checks the nominal tensor itself,
  // so such a rule is never checked at parse).
  InertiaRule inertia = InertiaRule::none;

  bool uses_parameter() const;
  bool holds() const;  // at the literal and nominal values
};

// A rule that a quantity is > 0 (strict) or >= 0, its run-time message "FIELD must be positive"
// or "FIELD must not be negative".
RangeRule sign_rule(const std::string& field, const Quantity& q, bool strict);

// Every rule of the scene, in the order parameter_error() checks them: the base, then per joint
// its link, gear and friction. given(field): whether the scene file gives an optional field (a
// fixed base's mass, a friction velocity); by default every one is taken as given.
std::vector<RangeRule> range_rules(const Scene& scene,
                                   const std::function<bool(const std::string&)>& given = {});

// Run-time parameter values against the scene's range for its numbers (yaml_reader.hpp), which
// holds at run time too: beyond 1e30 products overflow, below 1e-30 they run into subnormals.
// "" or "'p' = 1e+300 is outside the supported magnitude range 1e-30 .. 1e30 (or 0)" for the
// first value outside it. The compiled model and the recipe both check with it.
std::string parameter_range_error(const std::vector<std::string>& names,
                                  const std::vector<double>& values);
// The values that moved from the nominal ones, for a broken rule's message: "p = -3; Im = 2e-05"
// ("" if none moved).
std::string moved_parameters(const std::vector<std::string>& names,
                             const std::vector<double>& nominal, const std::vector<double>& values);

// "0.5", or "Im = 1e-5" for a parameter with its nominal value, for messages.
std::string shown(const Scene& scene, const Quantity& q);

}  // namespace spacearm
