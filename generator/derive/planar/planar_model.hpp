// The planar chain as a derived model (derived_model.hpp): the facts read from its scene (sizes,
// names, nominal values, actuated coordinates, the run-time parameter checks), its closed forms
// (symbolic_model.hpp), its recorded recursive algorithms (planar_chain.hpp) and its reference
// values (numeric_outputs.hpp). The one place where the planar derivation meets the generic stages.
#pragma once

#include "derived_model.hpp"
#include "symbolic_model.hpp"

namespace spacearm {

// The facts of the model (sizes, names, layout, outputs, the run-time parameter checks), read
// from the scene alone: no derivation.
ModelFacts planar_facts(const Scene& scene);

// The derived model refers to `model` (its closed forms and scene): keep `model` alive while
// it is used.
DerivedModel planar_derived_model(const SymbolicModel& model);

}  // namespace spacearm
