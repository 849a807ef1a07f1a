// Lowering: a derived model (derived_model.hpp) becomes the straight-line programs of
// function_spec.hpp. For each function it builds every candidate the model offers (the closed
// form through expression lowering, in each velocity basis; the recorded recursive algorithm;
// a composition of the ingredients), eliminates common subexpressions, checks each candidate
// against the derivation's own value at a check point, and keeps the cheapest. It never sees
// the scene: sizes, names and checks come with the model's facts.
#pragma once

#include "derived_model.hpp"
#include "function_spec.hpp"

namespace spacearm {

struct LowerOptions {
  // Baseline for the benchmarks: every entry as GiNaC's expanded expression, with no
  // common-subexpression elimination, no Horner scheme and a sin/cos call per occurrence
  // (what SymPy's ccode without cse gives). The model's name gets the suffix "_plain".
  bool plain = false;
};

LoweredModel lower(const DerivedModel& model, const LowerOptions& options = {});

}  // namespace spacearm
