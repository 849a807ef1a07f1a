// `spacearm eval`: every output a scene emits, at one state, as JSON (compiled and cached,
// or from GiNaC's expressions with --symbolic).
#pragma once

#include <string>
#include <vector>

namespace spacearm {

struct EvalArgs {
  std::string engine = "auto";  // --engine: CompileOptions::engine (compiled_model.hpp)
  std::string scene_path, q_text, qd_text, cache_dir;
  std::string qdd_text, forces_text,
      qdd_joints_text;   // inputs of the dynamics outputs (default zeros)
  std::string tau_text;  // joint torques, one per joint: Q = tau / p on the driven coordinates
  std::vector<std::string> param_assignments;
  // A free base's state in another tool's convention (runtime/state_conventions.hpp): --q and
  // --qd given in it, and the state also written in it.
  std::string state_from = "spacearm", state_to;
  bool compact_json = false, symbolic = false, verbose = false;
};

// Writes the JSON to standard output; returns the exit status. Throws on errors.
int run_eval(const EvalArgs& args);

}  // namespace spacearm
