// What a point-to-point plan takes from its scene, in one place: its joint bounds
// (StraightLineTask::effort, velocity, lower and upper) from the URDF's <limit effort velocity
// lower upper> (`spacearm plan --objective`, studies and Python), and the model it is planned on,
// with the exact state Jacobian for its steps (`plan`, studies and Python's Model.plan).
#pragma once

#include <algorithm>
#include <optional>
#include <vector>

#include "model_recipe.hpp"
#include "trajectory_planning.hpp"

namespace spacearm {

// Per joint, the URDF's effort and velocity limits and range on the link side (0: none).
inline void set_plan_limits(const ModelRecipe& recipe, StraightLineTask& task) {
  const std::vector<spatial::JointLimits> limits = recipe.joint_limits();
  task.effort = task.velocity = task.lower = task.upper =
      Eigen::VectorXd::Zero(recipe.facts().dims.num_links);
  for (size_t j = 0; j < limits.size(); ++j) {
    const spatial::JointLimits& l = limits[j];
    task.effort[long(j)] = l.effort, task.velocity[long(j)] = l.velocity;
    if (l.has_range()) task.lower[long(j)] = l.lower, task.upper[long(j)] = l.upper;
  }
}

// The scene with forward_dynamics_derivatives, where the task plans point to point and the scene
// lacks it (its steps' Jacobians then are exact, not central differences); nullopt where the
// scene's own model serves.
inline std::optional<ModelRecipe> planning_recipe(const ModelRecipe& scene,
                                                  const StraightLineTask& task) {
  const auto& emitted = scene.facts().outputs;
  if (!point_to_point(task.objective) ||
      std::find(emitted.begin(), emitted.end(), Output::forward_dynamics_derivatives) !=
          emitted.end())
    return std::nullopt;
  return scene.with_outputs({Output::forward_dynamics_derivatives},
                            "\n# a point-to-point plan: the state Jacobian\n");
}

}  // namespace spacearm
