// The planar chain's closed forms as straight-line programs: the variables their Horner scheme
// is written in. Sin/cos of the absolute body angles (relative ones by the angle-difference
// identities, so each body angle costs one sin/cos pair), the coordinates, and the velocity
// basis: qd, or the absolute body rates Omega_k.
#pragma once

#include <memory>

#include "expression_builder.hpp"
#include "symbolic_model.hpp"

namespace spacearm {

// free_floating adds the base's (x0, y0, q0); body_rates writes velocities as Omega_k.
std::unique_ptr<ExpressionBuilder> planar_builder(const SymbolicModel& model,
                                                  const Dimensions& dims, bool free_floating,
                                                  bool body_rates);

}  // namespace spacearm
