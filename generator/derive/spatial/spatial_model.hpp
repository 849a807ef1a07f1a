// The derived model of a spatial arm (spatial_scene.hpp): its facts, and each output the
// spatial chain gives (spatial_chain.hpp) as a recorded program with the same algorithm run in
// double as its reference. No closed forms: lowering keeps the recorded programs (formulation
// recursive). What lowering, the printer and the C interface need, and nothing of the scene.
#pragma once

#include <string>

#include "derived_model.hpp"
#include "spatial_scene.hpp"

namespace spacearm {

// The facts of the model (sizes, names, layout, outputs), read from the scene alone.
ModelFacts spatial_facts(const SpatialScene& scene);

// The scene must outlive the result (its recorders refer to it).
DerivedModel spatial_derived_model(const SpatialScene& scene);

}  // namespace spacearm
