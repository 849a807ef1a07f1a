// Symbolic model: the Lagrangian dynamics of a scene, derived with GiNaC.
// Follows the paper: kinetic energy eq. 3 (links) + eq. 10 with the factor 1/2 and
// eq. 11 (motors), M from eq. 6, C exactly as eq. 7, geared coordinates eq. 12.
// This module only derives: it never prints code (see cpp_emitter.hpp).
#pragma once

#include <ginac/ginac.h>

#include <map>
#include <string>
#include <vector>

#include "scene.hpp"

namespace spacearm {

// The closed forms and the symbols they are written in: all that expression lowering reads of a
// symbolic derivation (no scene: the facts lowering needs come with the derived model).
struct ClosedForms {
  // Symbols, created first and in a fixed order (coordinates, velocities, parameters) so
  // that GiNaC's term order, and so the emitted code, is reproducible.
  std::vector<GiNaC::symbol> q, qd, parameters;
  std::vector<double> nominal_parameters;  // the parameters' values where none are given
  // Absolute angle theta_k and rate Omega_k of body k = 0 (base) .. N; linear in q, qd.
  std::vector<GiNaC::ex> theta, omega;
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
  // Maps the arguments of cos/sin(theta_k) and cos/sin(theta_l - theta_k) to (k, l) (k = -1:
  // absolute angle of body l), for the lowering's one sin/cos pair per body angle.
  std::map<GiNaC::ex, std::pair<int, int>, GiNaC::ex_is_less> angle_table;
};

// A scene's derivation: its closed forms and the scene they were derived from.
struct SymbolicModel : ClosedForms {
  Scene scene;
};

struct DeriveOptions {
  // Derive every closed form, not only what the scene asks for (inspect); an error naming the
  // scene and kClosedFormLinks past the closed form's reach unless the scene's formulation is
  // closed.
  bool all_outputs = false;
};

// Converts a scene literal to an exact rational ("0.181" -> 181/1000).
GiNaC::numeric exact_decimal(const std::string& literal);

SymbolicModel derive(const Scene& scene, const DeriveOptions& options = {});

// Looks up an entry by the registry's symbol of an output: "T", "M[i][j]", "b[i]", ...
// (a vector takes one index, a matrix two). Throws on a bad name, index or missing output.
GiNaC::ex symbolic_entry(const SymbolicModel& model, const std::string& entry);

// An entry as `spacearm inspect` prints it: grouped by velocities and run-time parameters, so
// that p, p^2 and p_i p_j stand out; as LaTeX, and with decimal numbers instead of fractions,
// where asked.
std::string entry_text(const SymbolicModel& model, const std::string& entry, bool latex = false,
                       bool decimal = false);

// Numeric value of an expression at q, qd and parameter values (nominal if empty),
// with GiNaC's own arbitrary-precision evaluation.
double evaluate(const ClosedForms& model, const GiNaC::ex& e, const std::vector<double>& q,
                const std::vector<double>& qd, const std::vector<double>& params = {});
// The same for every entry of a matrix, row by row.
std::vector<double> evaluate(const ClosedForms& model, const GiNaC::matrix& m,
                             const std::vector<double>& q, const std::vector<double>& qd,
                             const std::vector<double>& params = {});

}  // namespace spacearm
