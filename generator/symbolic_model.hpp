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

// A trigonometric atom of the closed-form expressions: cos or sin of the absolute angle
// of body `to` (from == -1) or of the angle of body `to` relative to body `from`.
struct TrigAtom {
  bool is_cos = true;
  int from = -1;
  int to = 0;
};

struct SymbolicModel {
  Scene scene;
  // Symbols, created first and in a fixed order (coordinates, velocities, parameters) so
  // that GiNaC's term order, and so the emitted code, is reproducible.
  std::vector<GiNaC::symbol> q, qd, parameters;
  // Absolute angle theta_k and rate Omega_k of body k = 0 (base) .. N; linear in q, qd.
  std::vector<GiNaC::ex> theta, omega;
  // Constant Jacobian of the link-side relative joint angles with respect to q:
  // q_link = gear_map * q (identity for the reference model; 1/p_i on motor angles).
  GiNaC::matrix gear_map;

  GiNaC::ex kinetic_energy;           // T(q, qd), eq. 3 + eq. 10
  GiNaC::matrix mass_matrix;          // n x n, eq. 6
  GiNaC::matrix coriolis_matrix;      // n x n, eq. 7 (not the Christoffel form)
  GiNaC::matrix bias_forces;          // n x 1, C qd = d/dt dT/dqd - dT/dq at qdd = 0
  GiNaC::matrix momentum;             // 3 x 1, [Px, Py, L about the world origin]
  GiNaC::matrix end_effector_pose;    // 3 x 1, [x, y, phi] of the last link's tip
  GiNaC::matrix end_effector_jacobian;  // 3 x n, d pose / d q
  GiNaC::matrix joint_positions;        // 2 x (N + 1): joints 1..N, then the tip

  int n() const { return static_cast<int>(q.size()); }
  // Maps cos/sin(theta_k) and cos/sin(theta_l - theta_k) to their atoms; see atom_of().
  std::map<GiNaC::ex, std::pair<int, int>, GiNaC::ex_is_less> angle_table;
  // Identifies a trig function node of the derived expressions, or returns false.
  bool atom_of(const GiNaC::ex& trig_call, TrigAtom& atom) const;
};

struct DeriveOptions {
  bool all_outputs = false;  // derive everything, not only what the scene asks for
};

// Converts a scene literal to an exact rational ("0.181" -> 181/1000).
GiNaC::numeric exact_decimal(const std::string& literal);

SymbolicModel derive(const Scene& scene, const DeriveOptions& options = {});

// Looks up an entry by name: "T", "M[i][j]", "C[i][j]", "b[i]", "h[i]" (momentum),
// "x[i]" (end-effector pose), "J[i][j]" (end-effector Jacobian). Throws on a bad name.
GiNaC::ex symbolic_entry(const SymbolicModel& model, const std::string& entry);

// Numeric value of an expression at q, qd and parameter values (nominal if empty),
// with GiNaC's own arbitrary-precision evaluation.
double evaluate(const SymbolicModel& model, const GiNaC::ex& e, const std::vector<double>& q,
                const std::vector<double>& qd, const std::vector<double>& params = {});
// The same for every entry of a matrix, row by row.
std::vector<double> evaluate(const SymbolicModel& model, const GiNaC::matrix& m, const std::vector<double>& q,
                             const std::vector<double>& qd, const std::vector<double>& params = {});

}  // namespace spacearm
