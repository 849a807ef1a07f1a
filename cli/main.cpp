// spacearm: command-line front end of the generator.
//   spacearm generate SCENE -o DIR [--stats]   emit optimized C++ for a scene
//   spacearm inspect SCENE ENTRY [--latex]     print one symbolic entry, e.g. M[3][4]
//   spacearm eval SCENE --q ...                every output of a scene at a state, as JSON
//   spacearm simulate SCENE --torques F ...    integrate the dynamics, write CSV
//   spacearm plan SCENE --from P --to P ...    zero-momentum straight-line plan, write CSV
//   spacearm sweep STUDY -o DIR [--shard i/n]  the runs of a parameter study, one row each
//   spacearm view RUN.csv --scene S -o F.html  one self-contained page: the arm moving, plots
// Each subcommand's work is in its own file (generate_command, eval_command,
// simulate_command, plan_command, sweep_command, view_command); this file declares the options and
// maps errors to exit codes.
#include <CLI/CLI.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>

#include "compiled_model.hpp"
#include "cpp_printer.hpp"
#include "cli_input.hpp"
#include "generate_command.hpp"
#include "integrator_options.hpp"
#include "outputs.hpp"
#include "plan_command.hpp"
#include "eval_command.hpp"
#include "export_command.hpp"
#include "planar_scene.hpp"
#include "simulate_command.hpp"
#include "spatial_scene.hpp"
#include "sweep_command.hpp"
#include "view_command.hpp"

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
  bool adaptive = false;  // auto may choose rk4; an unknown integrator is named by run_simulate
  try {
    if (sim.integrator != "auto")
      adaptive = spacearm::adaptive(spacearm::method_from_string(sim.integrator));
  } catch (const std::invalid_argument&) {
  }
  for (const char* option : {"--rtol", "--atol"})
    if (command.count(option) && !adaptive)
      throw CLI::ValidationError(option,
                                 "applies only to the adaptive integrators (dopri5, rkf78, "
                                 "rosenbrock4), not to " +
                                     sim.integrator);
  for (const char* option : {"--interpolation", "--extrapolate"})
    if (command.count(option) && sim.zero_torque)
      throw CLI::ValidationError(option, "has no effect with --zero (no torque file)");
}

// An option given with an empty value (--q0 '', -o '') is an error, not its default: a script
// whose variable came out empty must not run something other than what it meant.
void refuse_empty_values(const CLI::App& command) {
  for (const CLI::Option* option : command.get_options()) {
    if (option->get_type_size() == 0 || option->count() == 0) continue;  // flags, absent
    for (const std::string& value : option->results())
      if (value.empty())
        throw CLI::ValidationError(option->get_name(),
                                   "an empty value; give one, or leave the option out for its "
                                   "default");
  }
}

// A CLI11 check: the option's text is one finite positive (or, allow_zero, non-negative)
// number, parsed strictly.
CLI::Validator positive_number(bool allow_zero = false) {
  return CLI::Validator(
      [allow_zero](std::string& text) -> std::string {
        try {
          const double v = spacearm::parse_number(text, "value");
          if (allow_zero ? !(v >= 0) : !(v > 0))
            return std::string(allow_zero ? "must not be negative" : "must be positive") +
                   ", got " + text;
        } catch (const std::exception& e) {
          return e.what();
        }
        return "";
      },
      "POSITIVE");
}

// Runs a subcommand: its errors become one "spacearm: error:" line and exit status 1.
// A compile still running in the background (--engine auto) finishes, after the output, so that
// the next run finds the model in the cache.
template <class Run>
int guarded(Run&& run) {
  int status = 1;
  try {
    status = run();
  } catch (const std::exception& e) {
    std::cerr << "spacearm: error: " << e.what() << "\n";
  }
  std::cout.flush();
  if (spacearm::background_compiles_running() > 0)
    std::cerr << "spacearm: finishing the model's compile for the cache (Ctrl-C stops it; the "
                 "next run then compiles again)\n";
  spacearm::finish_background_compiles();
  return status;
}

// --engine, for every command that runs a model.
void add_engine(CLI::App* command, std::string& engine) {
  command
      ->add_option("--engine", engine,
                   "auto: the model's interpreted code answers at once while its library "
                   "compiles in the background, then the compiled code (the same numbers); "
                   "interpreter: never compile; compiled: wait for the compiler")
      ->check(CLI::IsMember({spacearm::engine_name(spacearm::Engine::automatic),
                             spacearm::engine_name(spacearm::Engine::interpreter),
                             spacearm::engine_name(spacearm::Engine::compiled)}));
}

// The generate subcommand's options.
CLI::App* add_generate(CLI::App& app, spacearm::GenerateArgs& a) {
  auto* command =
      app.add_subcommand("generate", "Derive the model of a scene and emit C++ sources");
  command->add_option("scene", a.scene_path, "Scene file (YAML)")->required();
  command->add_option("-o,--output", a.out_dir, "Output folder")->required();
  command->add_flag("--stats", a.stats,
                    "Print adds, multiplies, divisions and sin/cos calls per function");
  command->add_option("--file-stem", a.file_stem,
                      "Name the files STEM.hpp/STEM.cpp instead of after the scene (the namespace "
                      "keeps the scene name)");
  command->add_flag(
      "--plain", a.plain,
      "Emit the benchmark baseline instead: expanded expressions without common-subexpression "
      "elimination (namespace and files NAME_plain)");
  command->add_flag("--check", a.check,
                    "Write nothing; exit 1 if the files in the output folder differ from what "
                    "would be generated");
  command->add_flag("--casadi", a.casadi,
                    "Also write STEM_c.cpp: the C interface, with every output as a CasADi "
                    "external function spacearm_casadi_<output> (casadi.external, acados); "
                    "compile it with -shared -fPIC");
  return command;
}

// The export subcommand's options.
CLI::App* add_export(CLI::App& app, spacearm::ExportArgs& a) {
  auto* command = app.add_subcommand(
      "export", "Write a spatial scene as another tool's model (--mjcf: MuJoCo's MJCF)");
  command->add_option("scene", a.scene_path, "Scene file (YAML, space: spatial)")->required();
  command->add_flag("--mjcf", a.mjcf,
                    "A MuJoCo model in space (no gravity, no contacts) in spacearm's coordinates, "
                    "except that a geared joint's angle is the link angle qm / p");
  command->add_option("-o,--output", a.output_file, "The model file to write")->required();
  command->add_option("--param", a.param_assignments,
                      "name=value: a run-time parameter's value (default: its nominal value)");
  command->add_flag("--compare", a.compare,
                    "Then load the file in MuJoCo and compare M, the bias and the forward "
                    "dynamics with spacearm's compiled model at 20 random states");
  command->add_option("--cache-dir", a.cache_dir,
                      "Compiled-model cache for --compare (default: $SPACEARM_CACHE_DIR, else "
                      "$XDG_CACHE_HOME/spacearm, else ~/.cache/spacearm)");
  command->add_flag("--balance-inertia", a.balance_inertia,
                    "Let MuJoCo change bodies whose inertia is not physical (balanceinertia) "
                    "instead of refusing them: its model then differs from spacearm's");
  return command;
}

// The inspect subcommand's options.
CLI::App* add_inspect(CLI::App& app, spacearm::InspectArgs& a) {
  auto* command = app.add_subcommand("inspect", "Print one symbolic entry of the derived model");
  command->add_option("scene", a.scene_path, "Scene file (YAML)")->required();
  std::string entry_help, spatial_help;
  for (const auto& o : spacearm::output_registry()) {
    if (o.composed_of.empty())
      entry_help += (entry_help.empty() ? "" : ", ") + std::string(o.symbol) + " (" + o.name + ")";
    if (spacearm::spatial_output(o.id, true))
      spatial_help += (spatial_help.empty() ? "" : ", ") + std::string(o.symbol);
  }
  command
      ->add_option(
          "entry", a.entry,
          "An entry such as M[3][4] or b[2]; the symbols: " + entry_help +
              "; of a spatial arm (printed as the statements computing it): " + spatial_help)
      ->required();
  command->add_flag("--latex", a.latex, "Print LaTeX instead of plain text");
  command->add_flag("--decimal", a.decimal,
                    "Show numeric coefficients as decimals instead of exact fractions");
  return command;
}

// The eval subcommand's options.
CLI::App* add_eval(CLI::App& app, spacearm::EvalArgs& a) {
  auto* command = app.add_subcommand(
      "eval", "Evaluate a scene's quantities at a state (compiled and cached, or --symbolic)");
  command->add_option("scene", a.scene_path, "Scene file (YAML)")->required();
  command->add_option("--q", a.q_text,
                      "Coordinates, comma-separated (default: the home state: base at the origin, "
                      "identity quaternion, joints at 0)");
  command->add_option("--qd", a.qd_text, "Velocities, comma-separated (default: zeros)");
  command->add_option("--qdd", a.qdd_text, "Accelerations for inverse_dynamics (default: zeros)");
  auto* forces = command->add_option("--forces", a.forces_text,
                                     "Generalized forces Q for forward_dynamics (default: zeros)");
  command
      ->add_option("--tau", a.tau_text,
                   "Joint torques instead of --forces, one per joint, on the link side (as "
                   "simulate --torques): Q = tau_i / p_i on the coordinate joint i drives (its "
                   "motor), eq. 14")
      ->excludes(forces);
  command->add_option("--qdd-joints", a.qdd_joints_text,
                      "Joint accelerations for free_base_inverse_dynamics (default: zeros)");
  command
      ->add_option("--param", a.param_assignments,
                   "Run-time parameter name=value (repeatable, once per name)")
      ->default_str("");
  command
      ->add_option("--state-from", a.state_from,
                   "A spatial free base's --q and --qd are in this tool's convention: "
                   "pinocchio, spacedyn or spart (joints as link angles; see docs/cli.md)")
      ->default_str("spacearm");
  command->add_option("--state-to", a.state_to,
                      "Also write the state in this tool's convention (state_NAME in the JSON)");
  command->add_flag("--json", a.compact_json, "Compact JSON on one line (default: indented JSON)");
  command->add_flag("--symbolic", a.symbolic,
                    "Evaluate GiNaC's expressions instead of the compiled code");
  command->add_flag("--verbose", a.verbose, "Report the time of each stage on stderr");
  command->add_option("--cache-dir", a.cache_dir, "Cache folder for compiled models");
  add_engine(command, a.engine);
  return command;
}

// The simulate subcommand's options.
CLI::App* add_simulate(CLI::App& app, spacearm::SimulateArgs& a) {
  auto* command = app.add_subcommand(
      "simulate", "Integrate a scene's dynamics under joint torques and write CSV");
  command->add_option("scene", a.scene_path, "Scene file (YAML)")->required();
  auto* torques_opt =
      command->add_option("--torques", a.torque_file,
                          "CSV of joint torques on a uniform time grid, columns found by name: "
                          "t,tau1,...,tauN (any order). tau_i is "
                          "the torque on link i's side of joint i (the gear's output); a geared "
                          "joint's motor gets tau_i/p_i (eq. 14)");
  auto* plan_opt =
      command
          ->add_option("--plan", a.plan_file,
                       "Replay a plan from spacearm plan (made on this scene or its rigid twin: "
                       "the same base and joints): its start mapped to this scene's coordinates "
                       "(motors at p q, springs pre-deflected for the first torque), its link-side "
                       "torques (a motor gets tau_i/p_i); --t-end defaults to its end")
          ->excludes(torques_opt);
  command
      ->add_flag("--other-arm", a.other_arm,
                 "With --plan: replay it even where this scene's end effector, from the plan's "
                 "joint angles, is not where the plan's was (another arm's kinematics): a "
                 "warning instead of the error")
      ->needs(plan_opt);
  command->add_flag("--zero", a.zero_torque, "No torques (free motion)")
      ->excludes(torques_opt)
      ->excludes(plan_opt);
  command
      ->add_option("--feedforward", a.feedforward,
                   "With --plan: none, or friction (add the scene's friction p f(p q') along the "
                   "planned rates to the torques; needs the output friction_forces)")
      ->check(CLI::IsMember({"none", "friction"}))
      ->needs(plan_opt)
      ->capture_default_str();
  command->add_option("--t-end", a.t_end, "End time [s] (required unless --plan)")
      ->check(positive_number())
      ->default_str("");
  command
      ->add_option("--integrator", a.integrator,
                   "auto: rk4 at a step that resolves the stiffest linearised mode at the start, "
                   "or rosenbrock4 where that step is over 10 times below --dt (says which and "
                   "why); or rk4, dopri5, rkf78, implicit_midpoint, rosenbrock4 (stiff scenes; "
                   "needs the output forward_dynamics_derivatives)")
      ->capture_default_str();
  command->add_option("--dt", a.dt, "Step of the fixed-step methods [s]")->check(positive_number());
  command->add_option("--dt-out", a.dt_out, "Output interval [s] (default: --dt)")
      ->check(positive_number())
      ->default_str("");
  command->add_option("--rtol", a.rtol, "Relative tolerance of the adaptive methods (at most 0.1)")
      ->check(positive_number())
      ->check(CLI::Validator(
          [](std::string& text) -> std::string {
            return std::strtod(text.c_str(), nullptr) <= 0.1
                       ? ""
                       : "must be at most 0.1 (a relative error of 10 %), got " + text;
          },
          "<= 0.1"));
  command->add_option("--atol", a.atol, "Absolute tolerance of the adaptive methods (>= 0)")
      ->check(positive_number(true));
  command
      ->add_option("--q0", a.q0_text,
                   "Initial coordinates (default: the home state: base at the origin, identity "
                   "quaternion, joints at 0; motor angles qm = p q if geared)")
      ->excludes(plan_opt);
  command->add_option("--qd0", a.qd0_text, "Initial velocities (default: zeros)")
      ->excludes(plan_opt);
  auto* consistent = command->add_flag(
      "--consistent-start", a.consistent_start,
      "Flexible joints: motor angles qm = p (q + e) and rates p qd instead of "
      "their --q0/--qd0 values, the springs pre-deflected by e to carry the torque "
      "at t = 0 (motor and link start with the same acceleration); --plan always "
      "starts so");
  consistent->excludes(plan_opt);
  command
      ->add_option("--param", a.param_assignments,
                   "Run-time parameter name=value (repeatable, once per name)")
      ->default_str("");
  command->add_option(
      "--interpolation", a.interpolation,
      "Torque between samples: linear, or hold (zero-order hold: each step sees one sample)");
  command->add_option(
      "--extrapolate", a.extrapolate,
      "Torque outside the file's time range: error (default), hold (first/last sample) or zero");
  command->add_option(
      "-o,--output", a.output_file,
      "CSV output (without -o, or -o -: standard output). Geared scenes get link-side columns q_i "
      "= qm_i/p_i "
      "and q_id, and the torque both as tau_i (link side) and tau_motor_i = tau_i/p_i");
  command
      ->add_option("--max-wall", a.max_wall,
                   "Wall-clock bound [s]: after 5 s, a run whose pace projects past it is "
                   "stopped (its rows kept) naming the stiffest mode")
      ->check(positive_number());
  command->add_option("--cache-dir", a.cache_dir, "Cache folder for compiled models");
  add_engine(command, a.engine);
  command->add_flag("--verbose", a.verbose, "Report the time of each stage on stderr");
  return command;
}

// The plan subcommand's options.
CLI::App* add_plan(CLI::App& app, spacearm::PlanArgs& a) {
  auto* command = app.add_subcommand("plan",
                                     "Plan a straight end-effector line (zero momentum for a free "
                                     "base; a redundant arm takes the minimum-norm joint rates) "
                                     "and write t, q, qd, qdd, torques as CSV");
  command->add_option("scene", a.scene_path, "Scene file (YAML)")->required();
  command
      ->add_option(
          "--from", a.from_text,
          "End-effector start: x,y (position; 2 joints or more) or x,y,phi (pose; 3 or more); "
          "for a spatial arm x,y,z (3 or more) or x,y,z,qw,qx,qy,qz (pose; 6 or more); a tree: "
          "once per --end-effector, in the same order")
      ->required()
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  command->add_option("--to", a.to_text, "End-effector goal, as --from (as often)")
      ->required()
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  command->add_option("--duration", a.duration, "Duration T [s]")
      ->required()
      ->check(positive_number())
      ->default_str("");
  command->add_option("--dt", a.dt, "Output grid [s]")->check(positive_number());
  command
      ->add_option("--time-law", a.time_laws,
                   "quintic (default) or cubic; a tree: once for every line, or once per "
                   "--end-effector")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll)
      ->check(CLI::IsMember({"quintic", "cubic"}));
  auto* elbow_opt = command->add_option(
      "--elbow", a.elbow,
      "Start branch: sign of joint 2's angle, +1 (default) or -1 (spatial: of every joint's "
      "0.4 rad seed)");
  command
      ->add_option(
          "--q0", a.q0_text,
          "Start configuration guess instead of --elbow (all coordinates; its base ones are kept)")
      ->excludes(elbow_opt);
  command
      ->add_option("--end-effector", a.end_effectors,
                   "A tree's end effector that follows the line, by name (eval lists them; "
                   "default: the first); repeated, several move at once, each along its own "
                   "--from/--to line")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  command
      ->add_option("--hold", a.hold,
                   "A tree's other arms while it moves: joints (every joint that does not carry "
                   "the moving end effector keeps its angle) or pose (the other end effectors "
                   "stay put in the inertial frame)")
      ->check(CLI::IsMember({"joints", "pose"}));
  command
      ->add_option("--objective", a.objective,
                   "line (default: the base turns as momentum conservation makes it), "
                   "reactionless (a free base's angular velocity held at zero through the "
                   "reaction null space: the task's rows plus 3 in 3D, 1 in the plane, need as "
                   "many joints), or from rest to rest at the --to position by any path, "
                   "min_base_rotation (the least integral of |omega_base|^2) or min_effort (of "
                   "|tau|^2), solved by IPOPT within the URDF's effort, velocity and angle limits")
      ->check(CLI::IsMember({"line", "reactionless", "min_base_rotation", "min_effort"}));
  command
      ->add_option("--knots", a.knots,
                   "min_base_rotation, min_effort: intervals of the piecewise-linear torques "
                   "(default 50; duration / dt a whole multiple of them)")
      ->each([&a](const std::string&) { a.knots_given = true; });
  command
      ->add_option("--effort-weight", a.effort_weight,
                   "min_base_rotation: weight of the effort (relative to the first guess's) "
                   "beside the rotation (relative to the straight line's); default 0.01")
      ->each([&a](const std::string&) { a.effort_weight_given = true; });
  command
      ->add_option("--param", a.param_assignments,
                   "Run-time parameter name=value (repeatable, once per name)")
      ->default_str("");
  command->add_option(
      "-o,--output", a.output_file,
      "CSV output (without -o, or -o -: standard output). Torques tau_i are link-side (and "
      "tau_motor_i = tau_i/p_i "
      "if geared); base_residual is max |(M qdd + b)_base| per row (free base)");
  command->add_option(
      "--torque-file", a.torque_file,
      "Also write t,tau1..N alone, the file simulate --torques reads (replay of the plan)");
  command->add_option("--cache-dir", a.cache_dir, "Cache folder for compiled models");
  add_engine(command, a.engine);
  command->add_flag("--verbose", a.verbose, "Report the stages on stderr");
  return command;
}

// The sweep subcommand's options.
CLI::App* add_sweep(CLI::App& app, spacearm::SweepArgs& a) {
  CLI::App* command = app.add_subcommand(
      "sweep", "Run a parameter study (grid or random draws) and write one row of metrics per run");
  command->add_option("study", a.study_path, "Study file (YAML)")->required();
  command->add_option("-o,--output", a.out_dir, "Results folder (created; a killed sweep resumes)")
      ->required();
  auto* shard = command->add_option("--shard", a.shard,
                                    "Run part i of n of the runs, e.g. 3/8 (default 1/1)");
  command
      ->add_option("--merge", a.merge,
                   "Folders of shards run apart (each copied whole: study.id, study.key, "
                   "runs-*.csv): their rows checked under each folder's own key and merged into "
                   "-o's results.csv, the same bytes as one sweep; nothing is run")
      ->excludes(shard)
      ->default_str("");
  command->add_option("--threads", a.threads, "Worker threads (default: one per hardware thread)")
      ->check(CLI::Range(1, 1024))
      ->default_str("");
  command->add_option("--cache-dir", a.cache_dir, "Cache folder for compiled models");
  add_engine(command, a.engine);
  command->add_flag("--verbose", a.verbose, "Report the stages on stderr");
  return command;
}

// The view subcommand's options.
CLI::App* add_view(CLI::App& app, spacearm::ViewArgs& a) {
  CLI::App* command = app.add_subcommand(
      "view",
      "Write one self-contained HTML page (no network, no server): a run's CSV drawn with its "
      "scene (the arm moving, plots linked to a time slider), or a study's results.csv as a map");
  command
      ->add_option("file", a.file,
                   "The CSV of simulate, plan, a sweep's series/run-*.csv or a table with the same "
                   "columns; or a sweep's results.csv")
      ->required();
  command->add_option("--scene", a.scene_path,
                      "The scene the run is of (required for a run: the arm is drawn from it)");
  command->add_option("--compare", a.compare_file,
                      "A second run of the same arm (e.g. the plan a replay follows), drawn as a "
                      "ghost beside the first, with their end effectors' distance plotted");
  command
      ->add_option("--param", a.param_assignments,
                   "Run-time parameter name=value the run used (repeatable, once per name)")
      ->default_str("");
  command->add_option("-o,--output", a.output_file, "The page (HTML)");
  command
      ->add_option("--max-frames", a.max_frames,
                   "Rows drawn per run: a longer file is thinned evenly (every k-th row and the "
                   "last) and the page says so")
      ->check(CLI::Range(2L, 1000000L));
  command
      ->add_option("--camera", a.camera,
                   "A run's first view: all (every run's path and the base), arm (the arm "
                   "alone, over the run), or x,y,z[,tx,ty,tz] in the world (3D: the point to "
                   "look from, and at; default the arm's centre); buttons switch all and arm")
      ->default_str("all");
  command->add_option("--cache-dir", a.cache_dir, "Cache folder for compiled models");
  add_engine(command, a.engine);
  command->add_flag("--verbose", a.verbose, "Report the stages on stderr");
  return command;
}

// The command line as one shell-quoted string (shown in the page).
std::string command_line(int argc, char** argv) {
  std::string line;
  for (int i = 0; i < argc; ++i) {
    std::string arg = argv[i];
    const bool plain = !arg.empty() && arg.find_first_not_of(
                                           "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                           "0123456789_-+=/.,:@%") == std::string::npos;
    if (!plain) {
      std::string quoted = "'";
      for (char c : arg) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
      arg = quoted + "'";
    }
    line += (line.empty() ? "" : " ") + arg;
  }
  return line;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"spacearm: symbolic dynamics of free-floating space manipulators, emitted as C++"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("spacearm ") + spacearm::kGeneratorVersion);
  app.option_defaults()->always_capture_default();  // every --help shows the defaults

  spacearm::GenerateArgs generate_args;
  spacearm::InspectArgs inspect_args;
  spacearm::EvalArgs eval_args;
  spacearm::SimulateArgs sim;
  spacearm::PlanArgs plan_args;
  spacearm::SweepArgs sweep_args;
  spacearm::ViewArgs view_args;
  spacearm::ExportArgs export_args;
  CLI::App* generate = add_generate(app, generate_args);
  add_inspect(app, inspect_args);
  CLI::App* eval = add_eval(app, eval_args);
  CLI::App* simulate = add_simulate(app, sim);
  CLI::App* plan = add_plan(app, plan_args);
  CLI::App* sweep = add_sweep(app, sweep_args);
  CLI::App* view = add_view(app, view_args);
  CLI::App* export_command = add_export(app, export_args);

  // Parse errors get the same prefix and exit code (1) as every other error; --help exits 0.
  try {
    app.parse(argc, argv);
    for (const CLI::App* command : app.get_subcommands()) refuse_empty_values(*command);
    if (*simulate) check_simulate_options(*simulate, sim);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) {  // --help: printed, and it must have arrived
      app.exit(e);
      return stdout_status();
    }
    std::cerr << "spacearm: error: " << e.what() << " (see --help)\n";
    return 1;
  }

  if (*simulate)
    return guarded([&] {
      if (!sim.zero_torque && sim.torque_file.empty() && sim.plan_file.empty())
        throw std::invalid_argument("simulate: give --torques FILE, --plan FILE or --zero");
      sim.command_line = command_line(argc, argv);
      return spacearm::run_simulate(sim);
    });
  if (*plan)
    return guarded([&] {
      plan_args.command_line = command_line(argc, argv);
      return spacearm::run_plan(plan_args);
    });
  if (*sweep) return guarded([&] { return spacearm::run_sweep_command(sweep_args); });
  if (*view)
    return guarded([&] {
      view_args.command_line = command_line(argc, argv);
      return spacearm::run_view(view_args);
    });
  if (*export_command) return guarded([&] { return spacearm::run_export(export_args); });
  if (*eval)
    return guarded([&] {
      const int status = spacearm::run_eval(eval_args);
      return status ? status : stdout_status();
    });
  return guarded([&] {
    const int status =
        *generate ? spacearm::run_generate(generate_args) : spacearm::run_inspect(inspect_args);
    return status ? status : stdout_status();
  });
}
