// The derived model: what a derivation hands to lowering, and the seam between the model kinds
// (the planar chain today, a spatial one next) and the generic stages after them. For each
// output lowering may get a closed form (GiNaC, in `closed_forms`' symbols), a recorder (a
// recursive algorithm run on recorded scalars), or both, and it always gets a reference value
// to check its program against; plus the model's facts (sizes, free base, passive forces,
// actuated coordinates, parameter checks). Lowering never sees the scene.
#pragma once

#include <Eigen/Core>

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "function_spec.hpp"

namespace spacearm {

struct ClosedForms;       // closed_forms.hpp (GiNaC)
class ExpressionBuilder;  // expression_builder.hpp (GiNaC)

// Entry i of an input array by its name ("q", "qd", "qdd", "Q", "qdd_joints", "params").
using InputValues = std::function<double(const std::string&, int)>;

// An output given by a recursive algorithm: recorded into a program, and the same algorithm run
// in double (the recorded program's reference, independent of its CSE). Results as the
// registry's, each row by row (a symmetric one in full).
struct RecordedForm {
  const char* algorithm = "";  // "CRBA", "RNEA", "ABA, forward-mode", ...
  std::function<std::vector<std::vector<SRef>>(Program&)> record;
  std::function<std::vector<std::vector<double>>(const InputValues&)> evaluate;
};

struct DerivedModel {
  ModelFacts facts;
  // The closed forms derived (nullptr: none, a model given only by recursive algorithms).
  const ClosedForms* closed_forms = nullptr;
  // A builder of the closed forms' nodes in the kind's variables (expression_builder.hpp), in
  // the plain velocities qd or, where the kind has them, the absolute body rates.
  std::function<std::unique_ptr<ExpressionBuilder>(bool body_rates)> closed_form_builder;
  // Whether the scene's formulation lets lowering try the recursive forms.
  bool tries_recursive = false;
  // The outputs a recursive algorithm can give.
  std::map<Output, RecordedForm> recorded;
  // The gear ratios (a model constant) where there are no closed forms to take them from.
  RecordedForm gear_ratios;
  // Any output's value (composed ones included) at inputs in the registry's order and sizes,
  // from the derivation alone: what composed programs are checked against.
  std::function<std::vector<Eigen::MatrixXd>(Output, const std::vector<Eigen::VectorXd>&,
                                             const Eigen::VectorXd&)>
      reference;

  bool has_closed_form(Output o) const;
  const RecordedForm* recorded_form(Output o) const {
    const auto it = recorded.find(o);
    return it == recorded.end() ? nullptr : &it->second;
  }
};

}  // namespace spacearm
