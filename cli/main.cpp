// spacearm: command-line front end of the generator.
//   spacearm generate SCENE -o DIR [--stats]   emit optimized C++ for a scene
//   spacearm inspect SCENE ENTRY [--latex]     print one symbolic entry, e.g. M[3][4]
//   spacearm eval SCENE --q ...                every output of a scene at a state, as JSON
//   spacearm simulate SCENE --torques F ...    integrate the dynamics, write CSV
//   spacearm plan SCENE --from P --to P ...    zero-momentum straight-line plan, write CSV
// Each subcommand's work is in its own file (generate_command, eval_command,
// simulate_command, plan_command); this file declares the options and maps errors to exit
// codes.
#include <CLI/CLI.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>

#include "compiled_model.hpp"
#include "cli_input.hpp"
#include "generate_command.hpp"
#include "outputs.hpp"
#include "plan_command.hpp"
#include "eval_command.hpp"
#include "scene.hpp"
#include "simulate_command.hpp"

namespace {

// 0 if everything written to standard output arrived, else 1 with a message (a full disk,
// /dev/full or a closed descriptor must not pass as success).
int stdout_status() {
  std::cout.flush();
  if (std::cout) return 0;
  std::cerr << "spacearm: error: writing standard output failed\n";
  return 1;
}

// Options that would have no effect are errors, not silently ignored.
void check_simulate_options(const CLI::App& command, const spacearm::SimulateArgs& sim) {
  const bool adaptive = sim.integrator == "dopri5" || sim.integrator == "rkf78";
  for (const char* option : {"--rtol", "--atol"})
    if (command.count(option) && !adaptive)
      throw CLI::ValidationError(option, "applies only to the adaptive integrators (dopri5, rkf78), not to " +
                                             sim.integrator);
  for (const char* option : {"--interpolation", "--extrapolate"})
    if (command.count(option) && sim.zero_torque)
      throw CLI::ValidationError(option, "has no effect with --zero (no torque file)");
}

// A CLI11 check: the option's text is one finite positive (or, allow_zero, non-negative)
// number, parsed strictly.
CLI::Validator positive_number(bool allow_zero = false) {
  return CLI::Validator(
      [allow_zero](std::string& text) -> std::string {
        try {
          const double v = spacearm::parse_number(text, "value");
          if (allow_zero ? !(v >= 0) : !(v > 0))
            return std::string(allow_zero ? "must not be negative" : "must be positive") + ", got " + text;
        } catch (const std::exception& e) {
          return e.what();
        }
        return "";
      },
      "POSITIVE");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"spacearm: symbolic dynamics of free-floating space manipulators, emitted as C++"};
  app.require_subcommand(1);

  auto* generate = app.add_subcommand("generate", "Derive the model of a scene and emit C++ sources");
  spacearm::GenerateArgs generate_args;
  generate->add_option("scene", generate_args.scene_path, "Scene file (YAML)")->required();
  generate->add_option("-o,--output", generate_args.out_dir, "Output folder")->required();
  generate->add_flag("--stats", generate_args.stats, "Print adds, multiplies, divisions and sin/cos calls per function");
  generate->add_option("--file-stem", generate_args.file_stem,
                       "Name the files STEM.hpp/STEM.cpp instead of after the scene (the namespace keeps the scene name)");
  generate->add_flag("--plain", generate_args.plain,
                     "Emit the benchmark baseline instead: expanded expressions without common-subexpression "
                     "elimination (namespace and files NAME_plain)");
  generate->add_flag("--check", generate_args.check,
                     "Write nothing; exit 1 if the files in the output folder differ from what would be generated");

  auto* inspect = app.add_subcommand("inspect", "Print one symbolic entry of the derived model");
  spacearm::InspectArgs inspect_args;
  inspect->add_option("scene", inspect_args.scene_path, "Scene file (YAML)")->required();
  std::string entry_help;
  for (const auto& o : spacearm::output_registry())
    if (o.composed_of.empty()) entry_help += (entry_help.empty() ? "" : ", ") + std::string(o.symbol) + " (" + o.name + ")";
  inspect->add_option("entry", inspect_args.entry, "An entry such as M[3][4] or b[2]; the symbols: " + entry_help)
      ->required();
  inspect->add_flag("--latex", inspect_args.latex, "Print LaTeX instead of plain text");
  inspect->add_flag("--decimal", inspect_args.decimal, "Show numeric coefficients as decimals instead of exact fractions");

  auto* eval = app.add_subcommand("eval", "Evaluate a scene's quantities at a state (compiled and cached, or --symbolic)");
  spacearm::EvalArgs eval_args;
  eval->add_option("scene", eval_args.scene_path, "Scene file (YAML)")->required();
  eval->add_option("--q", eval_args.q_text, "Coordinates, comma-separated")->required();
  eval->add_option("--qd", eval_args.qd_text, "Velocities, comma-separated (default: zeros)");
  eval->add_option("--qdd", eval_args.qdd_text, "Accelerations for inverse_dynamics (default: zeros)");
  eval->add_option("--forces", eval_args.forces_text, "Generalized forces Q for forward_dynamics (default: zeros)");
  eval->add_option("--qdd-joints", eval_args.qdd_joints_text,
                   "Joint accelerations for free_base_inverse_dynamics (default: zeros)");
  eval->add_option("--param", eval_args.param_assignments, "Run-time parameter name=value (repeatable, once per name)");
  eval->add_flag("--json", eval_args.compact_json, "Compact JSON on one line (default: indented JSON)");
  eval->add_flag("--symbolic", eval_args.symbolic, "Evaluate GiNaC's expressions instead of the compiled code");
  eval->add_flag("--verbose", eval_args.verbose, "Report the time of each stage on stderr");
  eval->add_option("--cache-dir", eval_args.cache_dir, "Cache folder for compiled models");

  auto* simulate = app.add_subcommand("simulate", "Integrate a scene's dynamics under joint torques and write CSV");
  spacearm::SimulateArgs sim;
  simulate->add_option("scene", sim.scene_path, "Scene file (YAML)")->required();
  auto* torques_opt = simulate->add_option(
      "--torques", sim.torque_file,
      "CSV of joint torques on a uniform time grid, columns found by name: t,tau1,...,tauN (any order). tau_i is "
      "the torque on link i's side of joint i (the gear's output); a geared joint's motor gets tau_i/p_i (eq. 14)");
  simulate->add_flag("--zero", sim.zero_torque, "No torques (free motion)")->excludes(torques_opt);
  simulate->add_option("--t-end", sim.t_end, "End time [s]")->required()->check(positive_number());
  simulate->add_option("--integrator", sim.integrator, "rk4, dopri5, rkf78 or implicit_midpoint");
  simulate->add_option("--dt", sim.dt, "Step of the fixed-step methods [s]")->check(positive_number());
  simulate->add_option("--dt-out", sim.dt_out, "Output interval [s] (default: --dt)")->check(positive_number());
  simulate->add_option("--rtol", sim.rtol, "Relative tolerance of the adaptive methods")->check(positive_number());
  simulate->add_option("--atol", sim.atol, "Absolute tolerance of the adaptive methods (>= 0)")
      ->check(positive_number(true));
  simulate->add_option("--q0", sim.q0_text, "Initial coordinates (default: zeros; motor angles qm = p q if geared)");
  simulate->add_option("--qd0", sim.qd0_text, "Initial velocities (default: zeros)");
  simulate->add_option("--param", sim.param_assignments, "Run-time parameter name=value (repeatable, once per name)");
  simulate->add_option("--interpolation", sim.interpolation,
                       "Torque between samples: linear, or hold (zero-order hold: each step sees one sample)");
  simulate->add_option("--extrapolate", sim.extrapolate,
                       "Torque outside the file's time range: error (default), hold (first/last sample) or zero");
  simulate->add_option("-o,--output", sim.output_file,
                       "CSV output; - or none: standard output. Geared scenes get link-side columns q_i = qm_i/p_i "
                       "and q_id, and the torque both as tau_i (link side) and tau_motor_i = tau_i/p_i");
  simulate->add_option("--cache-dir", sim.cache_dir, "Cache folder for compiled models");
  simulate->add_flag("--verbose", sim.verbose, "Report the time of each stage on stderr");

  auto* plan = app.add_subcommand(
      "plan", "Plan a straight end-effector line (zero momentum for a free base) and write t, q, qd, qdd, torques as CSV");
  spacearm::PlanArgs plan_args;
  plan->add_option("scene", plan_args.scene_path, "Scene file (YAML)")->required();
  plan->add_option("--from", plan_args.from_text, "End-effector start: x,y (position; 2 joints or more) or x,y,phi (pose; 3 or more)")
      ->required();
  plan->add_option("--to", plan_args.to_text, "End-effector goal, as --from")->required();
  plan->add_option("--duration", plan_args.duration, "Duration T [s]")->required()->check(positive_number());
  plan->add_option("--dt", plan_args.dt, "Output grid [s]")->check(positive_number());
  plan->add_option("--time-law", plan_args.time_law, "quintic (default) or cubic");
  auto* elbow_opt = plan->add_option("--elbow", plan_args.elbow, "Start branch: sign of joint 2's angle, +1 (default) or -1");
  plan->add_option("--q0", plan_args.q0_text,
                   "Start configuration guess instead of --elbow (all coordinates; its base ones are kept)")
      ->excludes(elbow_opt);
  plan->add_option("--param", plan_args.param_assignments, "Run-time parameter name=value (repeatable, once per name)");
  plan->add_option("-o,--output", plan_args.output_file,
                   "CSV output; - or none: standard output. Torques tau_i are link-side (and tau_motor_i = tau_i/p_i "
                   "if geared); base_residual is max |(M qdd + b)_base| per row (free base)");
  plan->add_option("--torque-file", plan_args.torque_file,
                   "Also write t,tau1..N alone, the file simulate --torques reads (replay of the plan)");
  plan->add_option("--cache-dir", plan_args.cache_dir, "Cache folder for compiled models");
  plan->add_flag("--verbose", plan_args.verbose, "Report the stages on stderr");

  // Parse errors get the same prefix and exit code (1) as every other error; --help exits 0.
  try {
    app.parse(argc, argv);
    if (*simulate) check_simulate_options(*simulate, sim);
    for (const CLI::App* command : {eval, simulate, plan})
      if (command->count("--cache-dir") && eval_args.cache_dir.empty() && sim.cache_dir.empty() &&
          plan_args.cache_dir.empty())
        throw CLI::ValidationError("--cache-dir", "empty path");
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::cerr << "spacearm: error: " << e.what() << " (see --help)\n";
    return 1;
  }

  if (*simulate) {
    try {
      if (!sim.zero_torque && sim.torque_file.empty())
        throw std::invalid_argument("simulate: give --torques FILE or --zero");
      return spacearm::run_simulate(sim);
    } catch (const std::exception& e) {
      std::cerr << "spacearm: error: " << e.what() << "\n";
      return 1;
    }
  }

  if (*plan) {
    try {
      return spacearm::run_plan(plan_args);
    } catch (const std::exception& e) {
      std::cerr << "spacearm: error: " << e.what() << "\n";
      return 1;
    }
  }

  if (*eval) {
    try {
      const int status = spacearm::run_eval(eval_args);
      return status ? status : stdout_status();
    } catch (const std::exception& e) {
      std::cerr << "spacearm: error: " << e.what() << "\n";
      return 1;
    }
  }

  try {
    const int status = *generate ? spacearm::run_generate(generate_args) : spacearm::run_inspect(inspect_args);
    return status ? status : stdout_status();
  } catch (const std::exception& e) {
    std::cerr << "spacearm: error: " << e.what() << "\n";
    return 1;
  }
}
