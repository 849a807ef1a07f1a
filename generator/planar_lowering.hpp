// Lowering of the planar model: its derived GiNaC expressions become the straight-line
// programs of function_spec.hpp. The planar choices live here and nowhere after: sin/cos of
// the absolute body angles (relative ones by the angle-difference identities, so each body
// angle costs one sin/cos pair), the velocity basis (qd or absolute body rates, whichever
// is cheaper), a multivariate Horner scheme, and common-subexpression elimination. Every
// program is checked against GiNaC's evaluation before it is handed on.
#pragma once

#include "function_spec.hpp"
#include "symbolic_model.hpp"

namespace spacearm {

struct LowerOptions {
  // Baseline for the benchmarks: every entry as GiNaC's expanded expression, with no
  // common-subexpression elimination, no Horner scheme and a sin/cos call per occurrence
  // (what SymPy's ccode without cse gives). The model's name gets the suffix "_plain".
  bool plain = false;
};

LoweredModel lower(const SymbolicModel& model, const LowerOptions& options = {});

}  // namespace spacearm
