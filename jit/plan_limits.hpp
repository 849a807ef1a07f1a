// A point-to-point plan's joint bounds (StraightLineTask::effort and velocity) from a scene's
// URDF <limit effort velocity>, as `spacearm plan --objective` and Python's plan() keep them.
#pragma once

#include <vector>

#include "model_recipe.hpp"
#include "trajectory_planning.hpp"

namespace spacearm {

// Per joint, the URDF's effort and velocity limits on the link side (0: none).
inline void set_plan_limits(const ModelRecipe& recipe, StraightLineTask& task) {
  const std::vector<spatial::JointLimits> limits = recipe.joint_limits();
  task.effort = task.velocity = Eigen::VectorXd::Zero(recipe.facts().dims.num_links);
  for (size_t j = 0; j < limits.size(); ++j)
    task.effort[long(j)] = limits[j].effort, task.velocity[long(j)] = limits[j].velocity;
}

}  // namespace spacearm
