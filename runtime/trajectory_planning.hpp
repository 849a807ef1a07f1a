// Trajectory planning by the inverse-dynamics approach (Basmadji, Seweryn and Sasiadek 2020,
// as used in the paper's Section 3): the end-effector follows a straight line in the world
// frame (position, or position and orientation: at a constant rate in the plane, slerped about
// one axis in 3D) while, for a free-floating base, the total momentum stays zero. Momentum
// conservation eliminates the base velocities (the generalized Jacobian, Umetani-Yoshida): v_task =
// J* z for the link-side joint rates z. Joint torques come from eq. 5 (M qdd + b, joint rows; times
// the gear ratio on the link side, eq. 14). Any chain: a fixed or free base, N >= 2 joints for a
// position task, N >= 3 for a pose. Redundant arms take the minimum-norm link-side joint rates z =
// J*^+ v_task. Dynamic sizes: the planner reads a model through DynamicModel (dynamic_model.hpp),
// so a linked Model<G> and a loaded CompiledModel share it. In 3D (N >= 3 for a position, N >= 6
// for a pose) it integrates dq/dt = f(q, qd) with the base's quaternion kept on the unit sphere.
// The functions on a DynamicModel are compiled once, in the runtime library
// (trajectory_planning.cpp).
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/QR>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "dynamic_model.hpp"
#include "integrator_options.hpp"
#include "model.hpp"
#include "text_numbers.hpp"

namespace spacearm {

enum class TimeLaw { quintic, cubic };

inline TimeLaw time_law_from_string(const std::string& s) {
  if (s == "quintic") return TimeLaw::quintic;
  if (s == "cubic") return TimeLaw::cubic;
  throw std::invalid_argument("unknown time law '" + s + "' (known: quintic, cubic)");
}

// Path parameter s(tau) in [0, 1] and its first two derivatives with respect to tau = t/T.
inline Eigen::Vector3d time_law(TimeLaw law, double tau) {
  tau = std::clamp(tau, 0.0, 1.0);
  const double t2 = tau * tau, t3 = t2 * tau;
  if (law == TimeLaw::cubic) return {3 * t2 - 2 * t3, 6 * tau - 6 * t2, 6 - 12 * tau};
  return {10 * t3 - 15 * t3 * tau + 6 * t3 * t2, 30 * t2 - 60 * t3 + 30 * t2 * t2,
          60 * tau - 180 * t2 + 120 * t3};
}

// What a tree's other end effectors do while one follows the line: hold their joints (every
// joint that does not carry the moving end effector keeps its angle) or hold their poses (each
// other end effector stays put in the inertial frame, the base moving under it).
enum class Hold { joints, pose };

inline Hold hold_from_string(const std::string& s) {
  if (s == "joints") return Hold::joints;
  if (s == "pose") return Hold::pose;
  throw std::invalid_argument("unknown hold '" + s + "' (known: joints, pose)");
}

// What a plan asks. Along the straight line: nothing more (the base turns as momentum
// conservation makes it), or no turn of a free base at all (reactionless: its angular velocity
// held at zero through the reaction null space of a redundant arm, Nenchev and Yoshida; the
// task's rows and the base's attitude rows, 3 in 3D and 1 in the plane, need as many joints).
// From start to goal by any path, at rest at both ends (optimal_plan.hpp, IPOPT): the least
// base rotation (the integral of |omega_base|^2) or the least effort (of |tau|^2).
enum class Objective { line, reactionless, min_base_rotation, min_effort };

inline Objective objective_from_string(const std::string& s) {
  if (s == "line") return Objective::line;
  if (s == "reactionless") return Objective::reactionless;
  if (s == "min_base_rotation") return Objective::min_base_rotation;
  if (s == "min_effort") return Objective::min_effort;
  throw std::invalid_argument("unknown objective '" + s +
                              "' (known: line, reactionless, min_base_rotation, min_effort)");
}
inline bool point_to_point(Objective o) {
  return o == Objective::min_base_rotation || o == Objective::min_effort;
}
// The task's fields an objective uses (another objective refuses them, never ignores them):
// knots point to point, the effort's weight in min_base_rotation, a time law on a line.
inline bool uses_knots(Objective o) { return point_to_point(o); }
inline bool uses_effort_weight(Objective o) { return o == Objective::min_base_rotation; }
inline bool uses_time_law(Objective o) { return !point_to_point(o); }

// A tree's end effector by name: its index among `names` (model `model`'s), else
// std::invalid_argument "'hand' is not an end effector of 'dual_arm7' ('l_tool', 'r_tool')",
// for the caller to prefix with its option or field. One place for plan's --end-effector,
// Python's end_effector and a study's manoeuvre.end_effector; the names are untrusted text.
inline int end_effector_index(const std::vector<std::string>& names, const std::string& name,
                              const std::string& model) {
  const auto it = std::find(names.begin(), names.end(), name);
  if (it != names.end()) return static_cast<int>(it - names.begin());
  std::string listed;
  for (const auto& n : names) listed += (listed.empty() ? "" : ", ") + quoted_text(n);
  throw std::invalid_argument(quoted_text(name) + " is not an end effector of " +
                              quoted_text(model) + " (" +
                              (names.empty() ? "a planar arm has one, unnamed" : listed) + ")");
}

struct StraightLineTask {
  // End-effector [x, y] (a position task) or [x, y, phi] (a pose task) at t = 0 and t = T; in
  // 3D [x, y, z] or [x, y, z, qw, qx, qy, qz] (the pose output's layout; any nonzero quaternion,
  // normalized).
  Eigen::VectorXd start = Eigen::Vector3d(1.5, 0.0, M_PI / 6);
  Eigen::VectorXd goal = Eigen::Vector3d(1.1, 0.0, M_PI / 6);
  double duration = 10.0;  // s
  double dt = 0.01;        // output grid of the plan
  TimeLaw law = TimeLaw::quintic;
  int elbow = +1;  // sign of the second joint angle at the start (3D: of every joint's seed)
  // Non-empty: the start configuration's guess (nq values) instead of the elbow seed. Its
  // base coordinates are kept; its joint angles are refined to put the end-effector at start.
  Eigen::VectorXd q0;
  // A tree's: the end effector that follows the line (its index among the model's), and what
  // the others do. A chain has one end effector and nothing to hold.
  int end_effector = 0;
  Hold hold = Hold::joints;
  // A tree's other end effectors that move at the same time, each along its own line (a position
  // or a pose, as start) with its own time law, over the same duration.
  struct Line {
    int end_effector = 0;
    Eigen::VectorXd start, goal;
    TimeLaw law = TimeLaw::quintic;
  };
  std::vector<Line> more_lines;
  Objective objective = Objective::line;
  // A point-to-point plan's (optimal_plan.hpp): the intervals of its torques' piecewise-linear
  // profile (T / knots a whole multiple of dt), and per joint the link-side bounds it keeps,
  // |tau_j| <= effort[j] and |q_j'| <= velocity[j] (empty, or 0 for a joint: none), and
  // lower[j] <= q_j <= upper[j] (empty, or lower[j] = upper[j] for a joint: none).
  int knots = 50;
  Eigen::VectorXd effort, velocity, lower, upper;
  // Whether the task bounds joint j's angle (lower[j] < upper[j]).
  bool has_range(int j) const {
    return lower.size() > j && upper.size() > j && lower[j] < upper[j];
  }
  // min_base_rotation's cost: the integral of |omega_base|^2 relative to the straight line's,
  // plus effort_weight times the integral of |tau|^2 relative to the first guess's.
  double effort_weight = 1e-2;
};

// A plan on the output grid. Vector: the model's coordinates; JointVector: link-side torques.
template <class Vector = Eigen::VectorXd, class JointVector = Eigen::VectorXd>
struct BasicPlan {
  std::vector<double> t;
  std::vector<Vector> q, qd, qdd;
  std::vector<JointVector> tau;  // link-side joint torques, eq. 5 joint rows times p (eq. 14)
  // Per sample: max |(M qdd + b)_base| with the planned qdd (zero up to rounding; empty for
  // a fixed base).
  std::vector<double> base_residual;
  // Independent checks with qdd taken by central differences of the planned qd over the grid
  // (O(dt^2)): the forces on the base, and the planned qdd itself.
  double max_base_residual = 0;
  double max_acceleration_mismatch = 0;
  double max_path_error = 0;  // max |x_task(q(t)) - x_desired(t)| (3D: and the angle's error)
  double max_momentum = 0;    // max |h(q, qd)| along the plan (free base; NaN if not emitted)
  // A tree's held end effectors' largest drift from their start poses (hold pose: position and
  // angle), or the held joints' from their start angles (hold joints); 0 for a chain.
  double max_hold_error = 0;
  bool held = false;  // a tree's plan: something held
  // How near the plan passes to a singularity of the generalized Jacobian (dynamic
  // singularities, Papadopoulos and Dubowsky): the smallest ratio of its row-scaled QR's
  // smallest to largest |R_ii| over the samples (an estimate of 1 / cond; the planner refuses
  // at kMinJacobianRcond and below), and where.
  double min_jacobian_rcond = 1;
  double min_jacobian_rcond_t = 0;
  // How far the base turned from its start attitude: the largest angle over the plan and the
  // angle at its end (rad; 0 for a fixed base). In 3D the angle of R0(t) R0(0)^T.
  double max_base_rotation = 0;
  double final_base_rotation = 0;
  // A point-to-point plan's (knots > 0): the flown end effector's distance from the goal at T,
  // the flight's largest distance from the solver's knots (its RK4 steps' error), the solver's
  // iterations, wall time and cost.
  int knots = 0;
  double goal_error = 0, max_knot_error = 0, cost = 0, solve_seconds = 0;
  int iterations = 0;
};
using Plan = BasicPlan<>;
template <class G>
using ModelPlan = BasicPlan<typename Model<G>::Vector, typename Model<G>::JointVector>;

// The integral of |tau|^2 over a plan's samples (trapezoidal): min_effort's cost.
template <class Vector, class JointVector>
double plan_effort(const BasicPlan<Vector, JointVector>& p) {
  double sum = 0;
  for (size_t k = 0; k + 1 < p.t.size(); ++k)
    sum += (p.t[k + 1] - p.t[k]) / 2 * (p.tau[k].squaredNorm() + p.tau[k + 1].squaredNorm());
  return sum;
}

// The names a caller gives the task's fields, for error messages (the CLI: its options).
struct TaskNames {
  std::string start = "start", goal = "goal", duration = "duration", dt = "dt", elbow = "elbow",
              q0 = "q0", end_effector = "end_effector", knots = "knots",
              effort_weight = "effort_weight";
  // A later line's start and goal: "start[k]" (a list's index, from 0) instead of the CLI's
  // "start K" (its K-th line, from 1).
  bool lines_indexed = false;
};

// Largest plan accepted: samples are held in memory until the plan is complete.
inline constexpr double kMaxPlanSamples = 1e6;

// The margin: a generalized Jacobian whose rcond (BasicPlan::min_jacobian_rcond) falls to this
// is singular, and the planner stops with the time and the reason.
inline constexpr double kMinJacobianRcond = 1e-10;

// The task's rows of the end-effector Jacobian for `values` pose values: in 3D a quaternion's
// four values are three angular velocities.
inline int task_rows(const DynamicModel& m, int values) {
  return m.spatial && values == 7 ? 6 : values;
}

// Checks a task against a model's sizes, before anything is computed; returns the task rows of
// the end-effector Jacobian: 2 (position) or 3 (pose) in the plane, 3 or 6 in 3D. Errors name
// the field (TaskNames).
int check_task(const DynamicModel& m, const StraightLineTask& task, const TaskNames& names = {});

// Joint angles that put the end-effector at task.start (the base at rest in its neutral
// configuration, or where task.q0 puts it), by Newton's method on the link-side joint angles with
// minimum-norm steps (at most 0.5 rad) and, for a redundant arm, a pull in the null space
// towards the seed, so that the start stays near it. In the plane `elbow` picks the branch by
// the sign of joint 2 and seeds the iteration; in 3D it is the sign of every joint's seed
// (0.4 rad, clear of the stretched arm's singularity). task.q0 replaces the seed.
Eigen::VectorXd initial_configuration(const DynamicModel& m, const StraightLineTask& task);

// The straight line of `task` for model `m` on the grid t = 0, dt, ..., T.
Plan plan_straight_line(const DynamicModel& m, const StraightLineTask& task);

namespace detail {
// For any plan's checks: the row-scaled rcond of the generalized Jacobian of task's moving end
// effectors at q, and qdd by central differences of the planned qd (max_acceleration_mismatch,
// and max_base_residual with it), skipping every kinks_every-th sample (> 1: where a
// point-to-point plan's torques turn, qdd's slope jumps and the differences are first order).
double generalized_jacobian_rcond(const DynamicModel& m, const StraightLineTask& task,
                                  const Eigen::VectorXd& q);
void check_by_central_differences(const DynamicModel& m, Plan& plan, int kinks_every = 0);
double base_rotation(const DynamicModel& m, const Eigen::VectorXd& q,
                     const Eigen::VectorXd& q_start);
}  // namespace detail

// A plan's own checks in one line, as `spacearm plan` and a sweep that plans print them: its
// samples, the largest path error and the largest |qdd - central differences of qd|.
inline std::string plan_checks_text(const Plan& plan) {
  char text[260];
  if (plan.knots > 0)
    std::snprintf(text, sizeof text,
                  "plan of %zu samples (%d knots, %d solver iterations in %.3g s, cost %.3e): "
                  "flown %.2e from the goal and %.2e from the knots, max |qdd - central "
                  "differences of qd| %.2e",
                  plan.t.size(), plan.knots, plan.iterations, plan.solve_seconds, plan.cost,
                  plan.goal_error, plan.max_knot_error, plan.max_acceleration_mismatch);
  else
    std::snprintf(text, sizeof text,
                  "plan of %zu samples: max path error %.2e, max |qdd - central differences of "
                  "qd| %.2e",
                  plan.t.size(), plan.max_path_error, plan.max_acceleration_mismatch);
  std::string out = text;
  if (plan.held) {
    std::snprintf(text, sizeof text, ", held end effectors or joints within %.2e",
                  plan.max_hold_error);
    out += text;
  }
  std::snprintf(text, sizeof text,
                ", generalized Jacobian's rcond at least %.2e (at t = %.6g s; singular at %.0e)",
                plan.min_jacobian_rcond, plan.min_jacobian_rcond_t, kMinJacobianRcond);
  out += text;
  if (plan.base_residual.empty()) return out;  // a fixed base
  std::snprintf(text, sizeof text, ", base turned at most %.2e rad (%.2e at the end)",
                plan.max_base_rotation, plan.final_base_rotation);
  return out + text;
}

// The plan as a table, as `spacearm plan` writes it and Python returns it: t, q, qd, qdd (by
// coordinate name, suffixes d and dd), a motor slot's link-side angle q_j and rate q_jd, the
// link-side torques tau1..N, for a geared model the
// motor torques tau_motor1..N = tau / p (eq. 14), for a free base base_residual, then the end
// effector's pose (end_effector_columns).
struct PlanTable {
  std::vector<std::string> names;
  std::vector<std::vector<double>> rows;
};
PlanTable plan_table(const Plan& plan, const DynamicModel& m, bool geared);

// The same for a linked model, in its fixed-size types.
template <class G>
ModelPlan<G> plan_straight_line(const Model<G>& model, const StraightLineTask& task) {
  const Plan p = plan_straight_line(dynamic_model(model), task);
  ModelPlan<G> out;
  out.t = p.t;
  out.base_residual = p.base_residual;
  out.max_base_residual = p.max_base_residual;
  out.max_acceleration_mismatch = p.max_acceleration_mismatch;
  out.max_path_error = p.max_path_error;
  out.max_momentum = p.max_momentum;
  out.max_hold_error = p.max_hold_error;
  out.held = p.held;
  out.min_jacobian_rcond = p.min_jacobian_rcond;
  out.min_jacobian_rcond_t = p.min_jacobian_rcond_t;
  out.max_base_rotation = p.max_base_rotation;
  out.final_base_rotation = p.final_base_rotation;
  out.knots = p.knots;
  out.goal_error = p.goal_error;
  out.max_knot_error = p.max_knot_error;
  out.cost = p.cost;
  out.solve_seconds = p.solve_seconds;
  out.iterations = p.iterations;
  for (size_t k = 0; k < p.t.size(); ++k) {
    out.q.emplace_back(p.q[k]);
    out.qd.emplace_back(p.qd[k]);
    out.qdd.emplace_back(p.qdd[k]);
    out.tau.emplace_back(p.tau[k]);
  }
  return out;
}

}  // namespace spacearm
