// Expression lowering: closed-form GiNaC expressions become nodes of a straight-line program.
// The variables an expression is written in are a policy of the model kind; the planar one
// (planar_builder) takes sin/cos of the absolute body angles (relative ones by the
// angle-difference identities, so each body angle costs one sin/cos pair), the velocity basis
// qd or the absolute body rates Omega_k, and a multivariate Horner scheme. The baseline
// (plain_builder) prints GiNaC's expanded expression node by node. No scene here: the
// builders read only the closed forms' symbols.
#pragma once

#include <ginac/ginac.h>

#include <memory>
#include <vector>

#include "outputs.hpp"
#include "straight_line.hpp"
#include "symbolic_model.hpp"

namespace spacearm {

class ExpressionBuilder {
 public:
  virtual ~ExpressionBuilder() = default;
  // The program the nodes are built in.
  virtual Program& program() = 0;
  // The node of an expression in the closed forms' symbols.
  virtual SRef build(const GiNaC::ex& e) = 0;
  // Makes `symbol` a variable whose value is an existing node (the solved qdd of a composed
  // output, which the state Jacobian's expressions then use).
  virtual void bind(const GiNaC::ex& symbol, SRef node) = 0;
};

// The planar chain's variables: free_floating adds the base's (x0, y0, q0); omega_basis writes
// velocities as absolute body rates.
std::unique_ptr<ExpressionBuilder> planar_builder(const ClosedForms& forms, const Dimensions& dims,
                                                  bool free_floating, bool omega_basis);
// The unoptimized baseline: nothing shared, a sin/cos call per occurrence, pow for powers (what
// SymPy's ccode without cse gives); its program does no hash-consing.
std::unique_ptr<ExpressionBuilder> plain_builder(const ClosedForms& forms);

// A matrix's entries row by row.
std::vector<GiNaC::ex> entries_of(const GiNaC::matrix& m);

}  // namespace spacearm
