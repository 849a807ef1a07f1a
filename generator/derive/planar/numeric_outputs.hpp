// The value of any output at a state, computed from the derivation alone: closed forms by
// GiNaC's evaluation (M and b by the recursive algorithms where only those were derived),
// composed outputs (registry's composed_of) by Eigen's dense solves and
// products of those values. It is what lowering checks its programs against and what
// `eval --symbolic` prints; it shares no code with the emitted programs.
#pragma once

#include <Eigen/Core>

#include <vector>

#include "symbolic_model.hpp"

namespace spacearm {

// inputs: in the registry's order and sizes (outputs.hpp); the results likewise.
std::vector<Eigen::MatrixXd> evaluate_output(const SymbolicModel& model, Output output,
                                             const std::vector<Eigen::VectorXd>& inputs,
                                             const Eigen::VectorXd& params);

}  // namespace spacearm
