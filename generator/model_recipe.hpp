// A scene of either kind, planar (scene.hpp) or spatial (spatial_scene.hpp, `space: spatial`), as
// what is made from it: the facts of its model, read from the scene alone, and its emitted code
// (the derivation, then lowering and the printer). What the generate command and the
// compile-and-load cache need, so neither asks which kind a scene is.
#pragma once

#include <Eigen/Core>

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "cpp_emitter.hpp"
#include "function_spec.hpp"
#include "planar_scene.hpp"
#include "spatial_scene.hpp"

namespace spacearm {

struct ClosedFormCache;  // model_recipe.cpp: the planar derivations, made on first use

// The most terms a spatial entry's expanded closed form may have for inspect to print it (the
// plane's closed forms are affordable to N = 8; a 3D entry's grows with the joints it spans).
constexpr size_t kSpatialClosedFormTerms = 400;

class ModelRecipe {
 public:
  explicit ModelRecipe(Scene scene);
  explicit ModelRecipe(SpatialScene scene);
  // Parses a scene file's text (SceneError naming the field); `space: spatial` picks the kind.
  static ModelRecipe parse(const std::string& text, const std::string& source_path);
  // Reads and parses a scene file (SceneError naming the file).
  static ModelRecipe load(const std::string& path) { return parse(read_scene_file(path), path); }

  const ModelFacts& facts() const { return facts_; }
  const std::string& name() const { return facts_.name; }
  // Every byte the model is made from: its hash names the cache entry and the library.
  const std::string& content() const;
  const std::string& source_path() const;
  // Why the run-time parameter values (in the scene's order) break the scene's range rules, as
  // the generated parameter_error() says it ("" if they do not): without compiling the model.
  std::string parameter_error(const std::vector<double>& params) const;
  // What a command says once on reading the scene (spatial bodies that inertia_check:
  // positive_definite takes though they are not physical), each naming the scene.
  std::vector<std::string> warnings() const;
  // The files besides the scene that it was read from (a spatial scene's URDF), as opened.
  std::vector<std::string> read_files() const;
  // Derives and emits the model; derive_ms (when given) receives the derivation's time.
  EmittedModel emit(const EmitOptions& options, double* derive_ms = nullptr) const;
  // One entry of the model's output ("M[3][4]", inspect's syntax). Planar: its closed form from
  // the derivation of every output (GiNaC; made on the first call and kept). Spatial: its closed
  // form where it is affordable (the recorded program expanded, at most kSpatialClosedFormTerms
  // terms; LaTeX or decimals on request), else the statements of its lowered program that it
  // depends on, ending in the entry's value (how the generated code computes it).
  // std::invalid_argument naming the entry, or saying that LaTeX and decimals need a closed form.
  std::string inspect_entry(const std::string& entry, bool latex = false,
                            bool decimal = false) const;
  // The closed forms' value of output o (a planar scene's derivation of its outputs, in GiNaC;
  // composed outputs by Eigen's solves) at inputs in the registry's order: the independent
  // reference `eval --symbolic` prints. Derived on the first call and kept; inspect_entry and this
  // take one process-wide lock for GiNaC, which is not thread-safe. derive_ms (when
  // given) receives the derivation's time, 0 once kept. std::invalid_argument for a spatial arm.
  std::vector<Eigen::MatrixXd> evaluate_symbolic(Output o,
                                                 const std::vector<Eigen::VectorXd>& inputs,
                                                 const Eigen::VectorXd& params,
                                                 double* derive_ms = nullptr) const;

  // Whether the model has closed forms (a planar derivation): what evaluate_symbolic needs.
  bool has_closed_forms() const { return planar_ != nullptr; }
  // The same scene with the outputs `extra` emitted too (those it already emits are kept once)
  // and `note` appended to its content (so the cache tells the two apart).
  ModelRecipe with_outputs(const std::vector<Output>& extra, const std::string& note) const;
  // Per joint, its name (a URDF's, else "joint1" ...) and a URDF's <limit> and <dynamics>
  // (none given for the YAML forms).
  std::vector<std::string> joint_names() const;
  std::vector<spatial::JointLimits> joint_limits() const;
  // Per joint, its gear ratio p (1 without a gear), a literal or a run-time parameter
  // (Quantity::index): joint torques act as tau / p (eq. 14).
  std::vector<Quantity> gear_ratios() const;
  // The base's mass, centre of mass and inertia about it at the nominal values (what the viewer
  // draws): (ixx, ixy, ixz, iyy, iyz, izz), of which the plane has izz alone.
  struct BaseInertial {
    double mass = 0;
    std::array<double, 3> com{};
    std::array<double, 6> inertia{};
  };
  BaseInertial base_inertial() const;
  // The base's centre of mass in its frame at the parameters' values (a spatial scene's; 0 in
  // the plane, whose base frame is at its centre of mass).
  std::array<double, 3> base_com(const std::vector<double>& params) const;
  // A URDF's <visual> shapes per body in its frame (what the viewer draws; none for YAML), and
  // the folder a mesh's path is relative to (the URDF's).
  std::vector<std::vector<spatial::Visual>> body_visuals() const {
    return spatial_ ? spatial_->body_visuals : std::vector<std::vector<spatial::Visual>>{};
  }
  std::string mesh_folder() const;
  // A spatial arm's bodies in the world at q (nq) and the parameters' values: per body (0 the
  // base) its position and its rotation's quaternion (w x y z), 7 numbers. Forward kinematics in
  // double, for drawing (the generated code has no such output).
  std::vector<std::array<double, 7>> body_poses(const std::vector<double>& q,
                                                const std::vector<double>& params) const;

 private:
  std::shared_ptr<const Scene> planar_;
  std::shared_ptr<const SpatialScene> spatial_;
  ModelFacts facts_;
  std::shared_ptr<ClosedFormCache> closed_forms_;  // shared by copies
  std::string spatial_entry(const std::string& entry, bool latex, bool decimal) const;
};

}  // namespace spacearm
