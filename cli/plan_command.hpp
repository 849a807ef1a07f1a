// `spacearm plan`: the zero-momentum straight-line plan (runtime/trajectory_planning.hpp) of a
// scene's compiled model, written as CSV: t, q, qd, qdd, the link-side joint torques and, for
// a free-floating base, the residual of the base rows of eq. 5; optionally the torques alone
// (t, tau1..N), as `spacearm simulate --torques` reads them.
#pragma once

#include <string>
#include <vector>

namespace spacearm {

struct PlanArgs {
  std::string engine = "auto";  // --engine: CompileOptions::engine (compiled_model.hpp)
  std::string scene_path, output_file, torque_file, cache_dir, q0_text;
  // --from, --to and --time-law: once, or once per --end-effector (a tree's lines, in order).
  std::vector<std::string> from_text, to_text, time_laws, end_effectors;
  std::string hold = "joints";     // a tree's --hold
  std::string objective = "line";  // --objective (Objective)
  int knots = 50;                  // --knots: a point-to-point plan's
  double effort_weight = 1e-2;     // --effort-weight: min_base_rotation's
  // Whether they were given: another objective refuses them rather than ignore them.
  bool knots_given = false, effort_weight_given = false;
  int elbow = +1;
  double duration = 0, dt = 0.01;
  std::vector<std::string> param_assignments;
  bool verbose = false;
  std::string command_line;  // recorded beside the CSV (provenance.hpp)
};

// Exit status: 0, or 1 on an error (message on stderr).
int run_plan(const PlanArgs& args);

}  // namespace spacearm
