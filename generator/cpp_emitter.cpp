#include "cpp_emitter.hpp"

#include <stdexcept>

#include "planar_model.hpp"

namespace spacearm {

EmittedModel emit_cpp(const SymbolicModel& model, const EmitOptions& options) {
  return emit_cpp(planar_derived_model(model), options);
}

LoweredModel lower(const SymbolicModel& model, const LowerOptions& options) {
  return lower(planar_derived_model(model), options);
}

EmittedModel emit_cpp(const DerivedModel& model, const EmitOptions& options) {
  if (options.plain && !model.closed_forms)
    throw std::invalid_argument("--plain: model " + model.facts.name +
                                " has no closed forms (a spatial arm is derived recursively)");
  LowerOptions lo;
  lo.plain = options.plain;
  PrintOptions po;
  po.scene_path = options.scene_path;
  po.command = options.command;
  po.file_stem = options.file_stem;
  po.c_units = options.c_units;
  po.leading_units = options.leading_units;
  po.interpreted = options.interpreted;
  po.casadi = options.casadi;
  return print_cpp(lower(model, lo), po);
}

}  // namespace spacearm
