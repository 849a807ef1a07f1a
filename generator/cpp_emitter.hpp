// The generator's pipeline from a derived model to C++: lowering (lowering.hpp) then printing
// (cpp_printer.hpp).
#pragma once

#include <string>
#include <vector>

#include "cpp_printer.hpp"
#include "derived_model.hpp"
#include "lowering.hpp"

namespace spacearm {

struct SymbolicModel;  // symbolic_model.hpp (GiNaC), included only where a model is derived

struct EmitOptions {
  std::string scene_path;  // as shown in the banner (keep it relative for reproducibility)
  std::string command;     // the regeneration command shown in the banner
  std::string file_stem;   // file names STEM.hpp/STEM.cpp; empty: the model's name
  bool plain = false;      // the benchmark baseline (see LowerOptions)
  int c_units = 1;         // PrintOptions::c_units
  std::vector<std::vector<std::string>> leading_units{};  // PrintOptions::leading_units
  bool interpreted = false;                               // PrintOptions::interpreted
  bool casadi = false;                                    // PrintOptions::casadi
};

EmittedModel emit_cpp(const SymbolicModel& model, const EmitOptions& options);
// lower(planar_derived_model(model), options): a planar derivation's programs.
LoweredModel lower(const SymbolicModel& model, const LowerOptions& options = {});
// Any derived model (a spatial arm's: spatial_model.hpp). `plain` needs closed forms.
EmittedModel emit_cpp(const DerivedModel& model, const EmitOptions& options);

}  // namespace spacearm
