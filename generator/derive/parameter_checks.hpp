// The scene's range rules (parameter_rules.hpp) that use a run-time parameter, as programs: the
// generated parameter_error() checks them for the parameters' values, for either kind of scene.
#pragma once

#include <vector>

#include "function_spec.hpp"
#include "parameter_rules.hpp"

namespace spacearm {

// Appends to facts.checks (in facts.checks_program, parameters by facts.parameter_names) each
// rule that is checked at run time and uses a parameter, in the rules' order.
void add_parameter_checks(const std::vector<RangeRule>& rules, ModelFacts& facts);

}  // namespace spacearm
