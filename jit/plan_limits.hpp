// A point-to-point plan's joint bounds (StraightLineTask::effort, velocity, lower and upper) from
// a scene's URDF <limit effort velocity lower upper>, as `spacearm plan --objective` and Python's
// plan() keep them.
#pragma once

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

}  // namespace spacearm
