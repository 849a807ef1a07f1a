// Symbolic model: the Lagrangian dynamics of a scene, derived with GiNaC.
// Follows the paper: kinetic energy eq. 3 (links) + eq. 10 with the factor 1/2 and
// eq. 11 (motors), M from eq. 6, C exactly as eq. 7, geared coordinates eq. 12.
// This module only derives: it never prints code (see cpp_emitter.hpp).
#pragma once

#include <ginac/ginac.h>

#include <map>
#include <string>
#include <vector>

#include "closed_forms.hpp"
#include "planar_scene.hpp"

namespace spacearm {

// A scene's derivation: its closed forms, the planar chain's body angles and rates that the
// closed forms' variables are made of (planar_expressions.hpp), and the scene.
struct SymbolicModel : ClosedForms {
  // Absolute angle theta_k and rate Omega_k of body k = 0 (base) .. N; linear in q, qd.
  std::vector<GiNaC::ex> theta, omega;
  // Maps the arguments of cos/sin(theta_k) and cos/sin(theta_l - theta_k) to (k, l) (k = -1:
  // absolute angle of body l), for the lowering's one sin/cos pair per body angle.
  std::map<GiNaC::ex, std::pair<int, int>, GiNaC::ex_is_less> angle_table;
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

}  // namespace spacearm
