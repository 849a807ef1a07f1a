// The native YAML form of a spatial arm (issue 31, first part): a base floating in 3D (or
// fixed) and a serial chain of revolute joints with any axes, read as untrusted input like every
// scene (yaml_reader.hpp: one document, known keys, bounded numbers; every error names the file,
// the line and the field).
//
//   name: arm7
//   space: spatial
//   base: {type: free_floating, mass: 500, com: [0, 0, 0], inertia: [ixx, ixy, ixz, iyy, iyz, izz]}
//   links:                                    # 1 to 30, each the child of the one before
//     - {origin: [x, y, z], rpy: [r, p, y], axis: [0, 0, 1], mass: 5, com: [...], inertia: [...]}
//   gears:                                    # optional: one mapping for all joints, or a list
//     {ratio: 100, rotor_inertia: [axial, transverse], rotor_coupling: exact}   # or armature
//     # a flexible joint adds stiffness: k [N m/rad] (and damping: d [N m s/rad]) between the
//     # gear's output qm / p and the link angle q; its motor angle qm follows all the joints
//   friction: {viscous: b, coulomb: Fc, velocity_scale: vs}   # optional, as in the plane
//   friction: {from_urdf: true, velocity_scale: vs}    # (URDF form) its joints' <dynamics>
//   end_effector: [x, y, z]                   # the tip in the last link's frame (default 0)
//   parameters: {m7: 1.0, p: 100}             # run-time parameters with their nominal values:
//                                             # any mass, com, inertia entry, ratio, rotor inertia
//   inertials: {link7: {mass: m7, com: [...], inertia: [...]}}   # (URDF form) a link's inertial
//                                             # given by the scene, in the link's frame
//   outputs: [mass_matrix, forward_dynamics]  # optional: what to emit (default: spatial_model.hpp)
//   inertia_check: physical                   # or positive_definite: identified tensors as given
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "parameter_rules.hpp"
#include "planar_scene.hpp"
#include "spatial_description.hpp"

namespace spacearm {

struct SpatialScene {
  std::string name;
  std::vector<std::string> joint_names;  // a URDF's moving joints (empty for the YAML form)
  std::vector<std::string> body_names;   // a URDF's link of each body, 0 the base (YAML: empty)
  std::vector<spatial::JointLimits> joint_limits;  // a URDF's, per moving joint (YAML: empty)
  // A URDF's shapes per body (0 the base, i link i), in the body's frame, for the viewer; a
  // mesh's path is relative to the URDF's folder (the folder of read_files[0]).
  std::vector<std::vector<spatial::Visual>> body_visuals;
  std::string source_path;  // as given (messages, the generated banner)
  std::string content;      // every byte the model is made from (its hash names the library)
  spatial::ChainDescription chain;
  std::vector<Output> outputs;  // as listed (`outputs:`); empty: the defaults (spatial_model.hpp)
  std::vector<Output> lanes;    // `lanes:` outputs also given for four states per call (ModelFacts)
  std::vector<Parameter> parameters;  // run-time parameters, params[i] in the generated code
  // The range rules on quantities that use a run-time parameter (parameter_rules.hpp): the
  // generated parameter_error() checks them for the parameters' values (the reader checks the
  // nominal ones as it reads).
  std::vector<RangeRule> run_time_rules;
  // The files it was read from besides itself, as opened (the URDF's path beside the scene):
  // a command refuses to write over them.
  std::vector<std::string> read_files;
  // What its bodies' inertia tensors must be (`inertia_check: physical | positive_definite`).
  InertiaRule inertia_check = InertiaRule::physical;
  // What a command says once on reading it (bodies positive_definite takes that are not physical).
  std::vector<std::string> warnings;
};

// A body's mass, centre of mass and inertia about it, in its frame, with the parts welded to it
// (a URDF's links whose inertial the scene gives) lumped in, each number as value() gives it (a
// literal's value, a parameter's nominal or run-time value); a massless whole keeps mass 0.
spatial::Inertial whole_body(const spatial::Link& l,
                             const std::function<double(const Quantity&)>& value,
                             bool exact_right_angles = false);

// The outputs a spatial arm can give today (the free-base ones only for a free base).
bool spatial_output(Output o, bool free_base);

// The outputs to emit, in the registry's order: the scene's list, else the registry's defaults
// that a spatial arm gives (as in the plane: the state Jacobian and Mdot only where asked for).
std::vector<Output> spatial_outputs(const SpatialScene& scene);
// The scene's needs:: bits (outputs.hpp): a free base; springs where a joint is flexible, else
// rigid joints; friction where a joint has some.
unsigned spatial_features(const SpatialScene& scene);

// A URDF file's text by the path the scene gives (`urdf:`); throws SceneError.
using UrdfFileReader = std::function<std::string(const std::string& path)>;

// Throws SceneError naming the field. A scene with `urdf:` reads the file through read_file;
// by default relative to the folder of source_name (at most 8 MB, a regular file or a pipe).
SpatialScene parse_spatial_scene(const std::string& yaml_text, const std::string& source_name,
                                 const UrdfFileReader& read_file = {});

// Whether a scene text says `space: spatial` at its top level (false for anything else, malformed
// text included: the planar reader then names what is wrong).
bool is_spatial_scene(const std::string& yaml_text);

}  // namespace spacearm
