// Recursive forms of the planar chain's dynamics, recorded into the same straight-line programs
// as the closed forms (so CSE, operation counts, the printer and the self-check are shared):
// recursive Newton-Euler for inverse dynamics and the bias (Featherstone, Rigid Body Dynamics
// Algorithms, 2008, ch. 5), the composite-rigid-body algorithm for M (ch. 6) and the
// articulated-body algorithm for forward dynamics (ch. 7), in planar spatial algebra with body
// frames. Each costs O(N) (M: O(N^2), its entries), where the closed form grows much faster.
// Derivatives (Mdot, C, Cc, the state Jacobian) run the same algorithms on dual numbers
// (forward-mode differentiation), one direction per pass: O(N) per column, O(N^2) in all.
//
// A geared joint's motor is its own body carried by the previous body, turning at
// Omega_{i-1} + qd_m (the exact coupling of eqs. 10 and 11); with rotor_coupling: armature it
// only adds I_m qdd_m on its coordinate. A rigid gear's coordinate moves two bodies, the link at
// qd_m / p and the rotor at qd_m, which ABA takes as one joint (both in the joint's D and U).
// This is the derivation stage, like symbolic_model.hpp: it knows bodies, gears and angles. The
// scalars are recorded_scalar.hpp's and the derivatives recursive_algorithms.hpp's, shared
// with any other chain.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "recursive_algorithms.hpp"
#include "planar_scene.hpp"
#include "straight_line.hpp"

namespace spacearm {

// The results of output o of the scene's planar chain (the registry's, each row by row; a
// symmetric one in full), recorded in p from its inputs p.input(name, i) under the registry's
// names and p.input("params", i).
std::vector<std::vector<SRef>> record_recursive(const Scene& scene, Output o, Program& p);

// The same algorithms run in double on the given inputs ("q", "qd", "qdd", "Q", "params"): the
// reference a recorded program is checked against, independent of the program's CSE.
std::vector<std::vector<double>> evaluate_recursive(
    const Scene& scene, Output o, const std::function<double(const std::string&, int)>& input);

}  // namespace spacearm
