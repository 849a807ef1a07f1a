// Point-to-point plans that spare the satellite (issue 53): the end effector from its start to
// a goal position in T seconds, at rest at both ends, by any path, with the least base rotation
// (the integral of |omega_base|^2, the base's angular velocity in its own frame) or the least
// effort (of |tau|^2, link side). Direct multiple shooting (Bock and Plitt): the state x_k =
// (q_k, v_k) at K + 1 knots and the link-side torques u_k, linear in time between knots (as a
// replay interpolates a plan's samples); each interval is one RK4 step whose exact Jacobians
// come from the model's state Jacobian (step_jacobian.hpp: rk4_step_in_coordinates), solved by
// IPOPT (Waechter and Biegler) with a limited-memory Hessian. The straight-line plan is the
// first guess. The result is flown: the torques on the output grid integrated by rkf78, so the
// plan's rows are the motion those torques make, and the plan says how far that lands from the
// goal and from the knots. Compiled in its own library (spacearm_optimal_plan), which links
// IPOPT; the runtime proper needs only Eigen.
#pragma once

#include <functional>

#include "dynamic_model.hpp"
#include "trajectory_planning.hpp"

namespace spacearm {

// Checks a point-to-point task (task.objective min_base_rotation or min_effort) against the
// model before anything is computed; errors name the field (TaskNames).
void check_point_to_point(const DynamicModel& m, const StraightLineTask& task,
                          const TaskNames& names = {});

// The plan of task.objective min_base_rotation or min_effort. `interrupted` (where given) is
// asked at every iteration of the solver; true stops it with an error ("interrupted"). One
// solve runs at a time in a process (IPOPT's sequential MUMPS keeps global state): others wait.
Plan plan_point_to_point(const DynamicModel& m, const StraightLineTask& task,
                         const std::function<bool()>& interrupted = {});

// Any objective: the straight line (line, reactionless) or point to point.
inline Plan plan_task(const DynamicModel& m, const StraightLineTask& task,
                      const std::function<bool()>& interrupted = {}) {
  return point_to_point(task.objective) ? plan_point_to_point(m, task, interrupted)
                                        : plan_straight_line(m, task);
}

}  // namespace spacearm
