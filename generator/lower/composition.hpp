// Composition: the outputs that the registry composes from others (outputs.hpp: composed_of),
// built in one straight-line program from their ingredients (M, b, the passive forces, J, the
// gear ratios): forward dynamics by an unrolled LDL^T solve, inverse dynamics by a product, the
// generalized Jacobian and free-base inverse dynamics by the base block's solve, the state
// Jacobian by the same factors. Knows shapes and the ingredients, not bodies or angles.
#pragma once

#include <vector>

#include "derived_model.hpp"
#include "expression_builder.hpp"

namespace spacearm {

// The results of composed output o (row by row), in fb's program.
std::vector<std::vector<SRef>> compose(const DerivedModel& model, ExpressionBuilder& fb, Output o);

}  // namespace spacearm
