// A spatial scene as a MuJoCo model (MJCF text), for users who cross-check in MuJoCo or run
// there (Basilisk's MJScene, learning environments): in space (no gravity, no contacts), in
// spacearm's coordinates. The base is a free joint at the base frame's origin carrying the
// satellite's whole inertial (URDF→MJCF converters often drop it); each joint a hinge at its
// link's origin on the link side, so MuJoCo's joint angle is the link angle q where spacearm's
// geared coordinate is the motor angle qm = p q (the file says so); an armature gear is
// MuJoCo's armature p^2 I_axial; viscous friction b on qm' is MuJoCo's damping p^2 b on q'.
// Each inertial is written in its principal axes (a double-precision eigendecomposition):
// MuJoCo's own of a fullinertia keeps only about 4e-7. Numbers are written with 17 digits.
// What MuJoCo has no counterpart for is refused, named (exact rotors, flexible joints, bodies
// that are not physical unless balance_inertia lets MuJoCo change them) or left out with a
// comment (smoothed Coulomb and Stribeck friction).
#pragma once

#include <string>
#include <vector>

#include "planar_scene.hpp"
#include "spatial_scene.hpp"

namespace spacearm {

struct MjcfOptions {
  // Run-time parameter values in the scene's order (empty: the nominal ones).
  std::vector<double> params;
  // Write `balanceinertia` for bodies whose inertia is not physical (inertia_check:
  // positive_definite): MuJoCo then changes their tensors, so its model differs from spacearm's.
  bool balance_inertia = false;
};

// The names the MJCF gives: the base's free joint (empty for a fixed base), each spacearm joint's
// hinge, and each joint's rotor hinge (empty where the joint has no exact rotor there).
struct MjcfNames {
  std::string base_joint;
  std::vector<std::string> joints, rotors;
};
MjcfNames mjcf_names(const SpatialScene& scene, const MjcfOptions& options = {});

// The MJCF text; std::invalid_argument naming the joint or body and what MuJoCo lacks.
std::string export_mjcf(const SpatialScene& scene, const MjcfOptions& options = {});

// A planar scene as the spatial arm that moves in its plane, at the parameters' values (its
// scene's order; empty: the nominal ones), for export_mjcf: the base's frame at its centre of
// mass (a free base moves in x, y and turns about z), each joint about z at the mount or the
// previous link's length along its x, the inertias about z as given (about x and y: the same
// value, which no planar motion excites and MuJoCo takes as physical), a motor's inertia as an
// exact rotor (the paper's eqs. 10-11) or armature, compensated from its link where the scene
// says so. Flexible joints are refused by export_mjcf; a coupling factor becomes exact at 1 and
// armature at 0 (refused between).
SpatialScene planar_as_spatial(const Scene& planar, const std::vector<double>& params = {});

}  // namespace spacearm
