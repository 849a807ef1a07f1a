// Closed forms: a derivation's outputs as GiNaC expressions and the symbols they are written in,
// whatever the model kind (the planar derivation makes them today, symbolic_model.hpp). What
// lowering reads of a symbolic derivation, with GiNaC's own evaluation of an expression (the
// reference its programs are checked against).
#pragma once

#include <ginac/ginac.h>

#include <map>
#include <vector>

#include "outputs.hpp"

namespace spacearm {

// The closed forms and the symbols they are written in: all that lowering reads of a symbolic
// derivation, of any kind (no scene: the facts lowering needs come with the derived model).
struct ClosedForms {
  // Symbols, created first and in a fixed order (coordinates, velocities, parameters) so
  // that GiNaC's term order, and so the emitted code, is reproducible.
  std::vector<GiNaC::symbol> q, qd, parameters;
  std::vector<double> nominal_parameters;  // the parameters' values where none are given
  // Constant Jacobian of the link-side relative joint angles with respect to q:
  // q_link = gear_map * q (identity for the reference model; 1/p_i on motor angles).
  GiNaC::matrix gear_map;
  std::vector<GiNaC::ex> ratios;  // gear ratio p_i per joint (1 without a gear): Q = tau / p

  GiNaC::ex potential_energy;  // V(q) of the joint springs (0 without)
  // Generalized forces besides M qdd + b: springs, dampers and friction, so that
  // M qdd + b + passive_forces = Q (n x 1; zero, and not used, in a scene without them).
  GiNaC::matrix passive_forces;
  bool has_passive_forces() const { return !passive_forces.is_zero_matrix(); }

  // For the state Jacobian (forward_dynamics_derivatives) only: symbols of the accelerations
  // and the partial derivatives of the residual R = M(q) qdd + b + passive_forces with them,
  // dR/dq (n x n) and dR/dqd (n x n); empty otherwise.
  std::vector<GiNaC::symbol> qdd;
  GiNaC::matrix residual_dq, residual_dqd;

  GiNaC::ex kinetic_energy;  // T(q, qd), eq. 3 + eq. 10 (0: no closed-form output needs it)
  // The closed-form outputs derived, by the registry's entries (outputs.hpp): each a matrix
  // of the registry's shape (1 x 1 for a scalar).
  std::map<Output, GiNaC::matrix> outputs;
  const GiNaC::matrix& expression(Output output) const;  // throws if not derived

  int n() const { return static_cast<int>(q.size()); }
};

// Numeric value of an expression at q, qd and parameter values (nominal if empty),
// with GiNaC's own arbitrary-precision evaluation.
double evaluate(const ClosedForms& model, const GiNaC::ex& e, const std::vector<double>& q,
                const std::vector<double>& qd, const std::vector<double>& params = {});
// The same for every entry of a matrix, row by row.
std::vector<double> evaluate(const ClosedForms& model, const GiNaC::matrix& m,
                             const std::vector<double>& q, const std::vector<double>& qd,
                             const std::vector<double>& params = {});

// A matrix's entries row by row.
std::vector<GiNaC::ex> entries_of(const GiNaC::matrix& m);

}  // namespace spacearm
