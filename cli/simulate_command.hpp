// `spacearm simulate`: a scene's compiled model integrated under joint torques from a CSV
// (runtime/torque_csv.hpp) or none, written as CSV rows that are never cut (row_writer.hpp).
// SIGINT and SIGTERM finish the current row, flush, report the time reached and exit with
// 130 and 143.
#pragma once

#include <string>
#include <vector>

namespace spacearm {

struct SimulateArgs {
  std::string engine = "auto";  // --engine: CompileOptions::engine (compiled_model.hpp)
  std::string scene_path, torque_file, output_file, cache_dir;
  bool zero_torque = false, verbose = false;
  // Flexible joints: set the motor coordinates to qm = p (q + e), the springs pre-deflected
  // for the torque at t = 0 (runtime/consistent_start.hpp), instead of taking them from --q0.
  bool consistent_start = false;
  std::string integrator = "auto", interpolation = "linear", extrapolate = "error";
  double t_end = 0, dt = 0.01, dt_out = 0, rtol = 1e-8, atol = 1e-10;
  std::string q0_text, qd0_text;
  // A plan from `spacearm plan` replayed into the scene (plan_replay.hpp): its start and its
  // torques instead of --q0, --qd0 and --torques; feedforward "friction" adds the scene's friction
  // along the planned rates to the torques.
  std::string plan_file, feedforward = "none";
  // Replay a plan whose end effector this scene puts elsewhere (another arm's kinematics): a
  // warning naming both scenes instead of the error.
  bool other_arm = false;
  // Wall-clock bound [s]: a run whose pace projects past it is stopped, its rows kept.
  double max_wall = 1800;
  std::vector<std::string> param_assignments;
  std::string command_line;  // recorded beside the CSV (provenance.hpp)
};

// Exit status: 0, 1 on an error (message on stderr), 128 + signal when interrupted.
int run_simulate(const SimulateArgs& args);

}  // namespace spacearm
