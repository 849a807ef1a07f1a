#include "simulate_command.hpp"

#include <algorithm>
#include <cmath>
#include <tuple>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <functional>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>

#include "cli_input.hpp"
#include "joint_limits.hpp"
#include "compiled_model.hpp"
#include "dynamic_model.hpp"
#include "consistent_start.hpp"
#include "integrator_choice.hpp"
#include "integrators.hpp"
#include "plan_replay.hpp"
#include "private_folder.hpp"
#include "provenance.hpp"
#include "span_note.hpp"
#include "row_writer.hpp"
#include "simulation.hpp"
#include "simulation_table.hpp"
#include "stop_on_signals.hpp"
#include "torque_csv.hpp"
#include "torque_signal.hpp"

namespace spacearm {

namespace {

// Thrown from the observer or the right-hand side when a stop was requested. Not a
// runtime_error, so that integrate() passes it on instead of reporting a failed step.
struct Interrupted {
  int signal;
};

void check_stop() {
  if (const int sig = cli::stop_signal()) throw Interrupted{sig};
}

// Thrown when the run's pace says it would take longer than --max-wall; like Interrupted, not a
// runtime_error, so that integrate() passes it on.
struct TooSlow {
  double projected_s, elapsed_s, t;
};

// The run's pace from the times the right-hand side is evaluated at: after 5 s of wall time, a
// run whose projected total passes --max-wall is stopped (a stiff mode forcing tiny steps would
// otherwise go quiet for hours; counting steps says nothing about their size).
class Pace {
 public:
  Pace(double t_end, double max_wall) : t_end_(t_end), max_wall_(max_wall) {}
  void at(double t) {
    if (++calls_ % 64 != 0) return;
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0_).count();
    if (elapsed < 5) return;
    const double projected = t > 0 ? elapsed * t_end_ / t : HUGE_VAL;
    if (projected > max_wall_ && (t > 0 || elapsed > 30)) throw TooSlow{projected, elapsed, t};
  }

 private:
  double t_end_, max_wall_;
  long calls_ = 0;
  std::chrono::steady_clock::time_point wall0_ = std::chrono::steady_clock::now();
};

// A torque or plan file: a regular file of at most 1 GB (read_regular_file).
std::string read_text_file(const std::string& path, const std::string& option) {
  try {
    return read_regular_file(path, option, size_t(1) << 30);
  } catch (const FolderError& e) {
    throw std::invalid_argument(e.what());
  }
}

// The torque signal of the run: from the samples of a torque or plan file (which must cover
// [0, t_end] unless asked to extrapolate), or zero.
std::unique_ptr<TorqueSignal<Eigen::Dynamic>> torque_signal(const SimulateArgs& a, int N,
                                                            const TorqueTable* table) {
  const Interpolation mode = interpolation_from_string(a.interpolation);
  const Extrapolation outside = extrapolation_from_string(a.extrapolate);
  if (!table) {
    const std::vector<Eigen::VectorXd> zero{Eigen::VectorXd::Zero(N), Eigen::VectorXd::Zero(N)};
    return std::make_unique<TorqueSignal<Eigen::Dynamic>>(0.0, a.t_end, zero,
                                                          Interpolation::linear);
  }
  const bool plan = !a.plan_file.empty();
  const std::string gap = coverage_gap(table->t0, table->t_last(), a.t_end);
  if (outside == Extrapolation::error && !gap.empty())
    throw std::invalid_argument(std::string(plan ? "--plan '" : "--torques '") +
                                (plan ? a.plan_file : a.torque_file) + "' covers " + gap +
                                ": give a file that covers it, or --extrapolate hold or "
                                "--extrapolate zero");
  return std::make_unique<TorqueSignal<Eigen::Dynamic>>(table->t0, table->dt, table->samples, mode,
                                                        outside);
}

// A plan made for another arm is refused (or, with --other-arm, replayed with a warning):
// the scene's end effector from the plan's joint angles must be where the plan's was. The
// plan's provenance names the scene it was made on.
void check_same_arm(const SimulateArgs& a, const DynamicModel& model, const PlanSamples& plan) {
  bool compared = false;
  const std::string mismatch = plan_kinematics_mismatch(model, plan, &compared);
  if (!compared)
    std::fprintf(stderr,
                 "spacearm: note: --plan '%s' has no end-effector columns (or the scene emits no "
                 "end_effector_pose): whether it was made for this arm is not checked\n",
                 a.plan_file.c_str());
  if (mismatch.empty()) return;
  std::string made_on = "another scene";
  try {
    if (const auto p = cli::read_provenance(a.plan_file)) made_on = "'" + p->scene + "'";
  } catch (const std::exception&) {  // an unreadable record names nothing: the error still holds
  }
  const std::string what = "--plan '" + a.plan_file + "' was made on " + made_on +
                           ", whose kinematics differ from the scene '" + a.scene_path +
                           "': " + mismatch;
  if (!a.other_arm)
    throw std::invalid_argument(what +
                                "; replan on this scene, or add --other-arm to replay it "
                                "anyway");
  std::fprintf(stderr, "spacearm: warning: %s (replayed as --other-arm asks)\n", what.c_str());
}

// A plan's replay into this model: friction fed forward if asked, a warning where friction
// outweighs the planned torque, and the start mapped to the model's coordinates.
void prepare_replay(const SimulateArgs& a, const DynamicModel& model, PlanSamples& plan,
                    Eigen::VectorXd& q0, Eigen::VectorXd& qd0) {
  if (a.feedforward == "friction") {
    feed_friction_forward(model, plan);
  } else if (model.friction_forces) {
    if (const std::vector<int> stalled =
            joints_stalled_by_friction(plan, friction_along(model, plan));
        !stalled.empty()) {
      std::string joints;
      for (int j : stalled) joints += (joints.empty() ? "" : ", ") + std::to_string(j);
      std::fprintf(stderr,
                   "spacearm: warning: along the plan, friction (p f(p q')) reaches the planned "
                   "torque's peak at joint %s: those joints stall or lag; add --feedforward "
                   "friction\n",
                   joints.c_str());
    }
  }
  check_same_arm(a, model, plan);
  const Eigen::VectorXd e = replay_start(model, plan, plan.torques.samples.front(), q0, qd0);
  if (e.size() && e.cwiseAbs().maxCoeff() > 1e-9)
    std::fprintf(stderr,
                 "spacearm: plan start: springs pre-deflected by up to %.3g rad (link side) "
                 "to carry its first torque\n",
                 e.cwiseAbs().maxCoeff());
}

// The header, and a sample as a row of its columns.
std::string header(const SimulationTable& table) {
  std::string h;
  for (const auto& n : table.names()) h += (h.empty() ? "" : ",") + n;
  return h + "\n";
}

std::string row(const std::vector<double>& values) {
  std::string r;
  char buf[32];
  for (double v : values) {
    std::snprintf(buf, sizeof buf, r.empty() ? "%.17g" : ",%.17g", v);
    r += buf;
  }
  return r + "\n";
}

// The output grid in the options' own names: rows every --dt-out, or every --dt when it is not
// given; --t-end a whole multiple of it, and a fixed step dividing it. note(): what a step chosen
// too small for any run is put down to (the parameters' span of values), appended.
void check_output_grid(const SimulateArgs& a, double dt_out, const IntegratorOptions& opt,
                       const std::function<std::string()>& note) {
  const char* every = a.dt_out > 0 ? "--dt-out" : "--dt";
  char buf[300];
  const double rows = a.t_end / dt_out;
  if (!(rows >= 0.5) || rows > 1e12 ||
      std::abs(std::round(rows) * dt_out - a.t_end) > 1e-9 * std::max(1.0, a.t_end)) {
    std::snprintf(buf, sizeof buf,
                  "--t-end %.10g s must be a whole multiple of %s %.10g s (a row every %s)",
                  a.t_end, every, dt_out, every);
    throw std::invalid_argument(buf);
  }
  if (adaptive(opt.method)) return;
  const double per = dt_out / opt.dt;
  // A step this small is no run: say so before the grid's check (whose count would overflow).
  if (per > 1e9 && a.integrator == "auto") {
    std::snprintf(buf, sizeof buf,
                  "simulate: %s would take %.3g steps of %.3g s for each row (%s %.10g s): the "
                  "stiffest mode at the start is too fast for any run",
                  to_string(opt.method).c_str(), per, opt.dt, every, dt_out);
    throw std::invalid_argument(buf + note());
  }
  if (per > 1e9) {
    std::snprintf(buf, sizeof buf,
                  "--dt %.10g s is too small for a row every %s %.10g s (%.3g steps a row)", opt.dt,
                  every, dt_out, per);
    throw std::invalid_argument(buf);
  }
  if (a.dt_out == 0) return;
  if (!(per >= 0.5) || std::abs(std::round(per) * opt.dt - dt_out) > 1e-9 * dt_out) {
    std::snprintf(buf, sizeof buf,
                  "--dt-out %.10g s must be a whole multiple of the step --dt %.10g s", dt_out,
                  opt.dt);
    throw std::invalid_argument(buf);
  }
}

// Says so before a run whose CSV would pass 1 GB.
void warn_if_large(const SimulateArgs& a, double dt_out, int columns) {
  const double rows = a.t_end / dt_out + 1, bytes = rows * columns * 24.0;
  if (bytes > 1e9)
    std::fprintf(stderr,
                 "spacearm: note: the output will be about %.3g GB (%.3g rows of %d columns); "
                 "a larger --dt-out thins it\n",
                 bytes / 1e9, rows, columns);
}

// What was written when the run stopped early, on stderr: the last row's time in the fewest
// digits that read back as it (51.2, not 51.200000000000003).
void report_stop(const RowWriter& out, double t_reached, const std::string& why) {
  char t[32];
  for (int digits = 6; digits <= 17; ++digits) {
    std::snprintf(t, sizeof t, "%.*g", digits, t_reached);
    if (std::strtod(t, nullptr) == t_reached) break;
  }
  std::fprintf(stderr, "spacearm: %s; %s holds every row up to t = %s s\n", why.c_str(),
               out.where().c_str(), t);
}

// The integrator asked for; auto (the default) decides from the model's stiffest mode at the
// start (integrator_choice.hpp) and says which and why.
IntegratorOptions integrator_options(const SimulateArgs& a, const StiffestMode& mode,
                                     bool has_state_jacobian, double dt_out) {
  IntegratorOptions opt;
  opt.dt = a.dt;
  opt.rtol = a.rtol;
  opt.atol = a.atol;
  if (a.integrator != "auto") {
    opt.method = method_from_string(a.integrator);
    // As asked, but not in silence: a step that does not resolve the stiffest mode drifts
    // momentum and energy (|lambda| dt > 1), or diverges (beyond about 2.8).
    if (opt.method == Method::rk4 && mode.rate * opt.dt > 1)
      std::fprintf(
          stderr,
          "spacearm: warning: rk4 at dt = %g s does not resolve the stiffest mode at the "
          "start, %s (|lambda| dt = %.3g; %s): expect momentum and energy to drift; "
          "--integrator auto would take dt = %.3g s\n",
          opt.dt, describe(mode).c_str(), mode.rate * opt.dt,
          unstable_for_rk4(mode, opt.dt) ? "unstable beyond about 2.8" : "accurate below 1",
          1 / mode.rate);
    return opt;
  }
  const IntegratorChoice choice = choose_integrator(mode, a.dt, dt_out, has_state_jacobian);
  choice.apply(opt);
  std::fprintf(stderr, "spacearm: integrator: %s\n", choice.why.c_str());
  return opt;
}

// An integration that failed where the start's stiffest mode explains it: the mode and the
// remedy instead of the state's numbers.
std::string failure_advice(const IntegrationError& e, const IntegratorOptions& opt,
                           const StiffestMode& mode) {
  std::string what = e.what();
  if (opt.method != Method::rk4) return what;
  const bool diverged = what.find("the state left the model's domain") != std::string::npos;
  if (!unstable_for_rk4(mode, opt.dt) && !diverged) return what;
  what = what.substr(0, what.find("; last accepted state"));
  char buf[600];
  if (!unstable_for_rk4(mode, opt.dt)) {  // resolved at the start: a faster mode came later
    std::snprintf(buf, sizeof buf,
                  " (last accepted t = %.6g s): rk4 at dt = %g s diverged; the stiffest mode at "
                  "the start, %s, was stable at this step (|lambda| dt = %.3g), so a faster one "
                  "the motion reached later was not; run with a smaller --dt, or --integrator "
                  "dopri5 (adaptive)",
                  e.t(), opt.dt, describe(mode).c_str(), mode.rate * opt.dt);
    return what + buf;
  }
  std::snprintf(buf, sizeof buf,
                " (last accepted t = %.6g s): rk4 at dt = %g s is unstable for the stiffest mode "
                "at the start, %s (|lambda| dt = %.3g, stable below about 2.8); run with "
                "--integrator auto or rosenbrock4, or --dt %.2g",
                e.t(), opt.dt, describe(mode).c_str(), mode.rate * opt.dt, 1 / mode.rate);
  return what + buf;
}

// The scene's model, compiled or from the cache, with the stages reported under --verbose.
CompiledModel load_model(const SimulateArgs& a, const ModelRecipe& scene) {
  CompileOptions options;
  options.cache_dir = a.cache_dir;
  options.engine = parse_engine(a.engine);
  options.call_first(Output::forward_dynamics);  // the integration's: compiled first
  // By value: a compile in the background says its last stage after this function returns.
  options.progress = [verbose = a.verbose](const std::string& m) {
    if (verbose || worth_saying(m)) std::fprintf(stderr, "spacearm: %s\n", m.c_str());
  };
  StageReport rep;
  CompiledModel model = CompiledModel::load(scene, options, &rep);
  if (a.verbose) std::fprintf(stderr, "spacearm: %s\n", stage_line(rep).c_str());
  return model;
}

// Momentum of a free-floating run (no external force: conserved whatever the joint torques)
// and, where nothing drives or dissipates, energy: how far they drifted, said at the end.
class Invariants {
 public:
  Invariants(const std::vector<std::string>& names, const DynamicModel& model, bool conservative) {
    const std::vector<std::string> momentum =
        model.free_floating ? momentum_columns(model) : std::vector<std::string>{};
    const size_t linear = model.spatial ? 3 : 2;  // Px, Py (, Pz), then the angular part
    for (size_t c = 0; c < names.size(); ++c) {
      const std::string& n = names[c];
      const auto k = std::find(momentum.begin(), momentum.end(), n);
      if (k != momentum.end())
        (static_cast<size_t>(k - momentum.begin()) < linear ? linear_ : angular_).push_back(c);
      if (conservative && (n == "kinetic_energy" || n == "potential_energy")) energy_.push_back(c);
    }
  }
  void row(const std::vector<double>& v) {
    if (first_.empty()) first_ = v;
    for (const auto& [columns, drift, scale] :
         {std::tuple{&linear_, &linear_drift_, &linear_scale_},
          std::tuple{&angular_, &angular_drift_, &angular_scale_}}) {
      double d = 0, n = 0;
      for (size_t c : *columns) {
        d += (v[c] - first_[c]) * (v[c] - first_[c]);
        n += v[c] * v[c];
      }
      *drift = std::max(*drift, std::sqrt(d));
      *scale = std::max(*scale, std::sqrt(n));
    }
    if (!energy_.empty()) {
      double e = 0, e0 = 0;
      for (size_t c : energy_) e += v[c], e0 += first_[c];
      energy_drift_ = std::max(energy_drift_, std::abs(e - e0));
      energy_scale_ = std::max(energy_scale_, std::abs(e));
    }
  }
  // The line for stderr; empty when there is nothing to say.
  std::string report() const {
    if (first_.empty() || (linear_.empty() && energy_.empty())) return "";
    std::string out = "spacearm: invariants over the run:";
    auto relative = [](double drift, double scale) {
      if (!(scale > 1e-12)) return std::string();
      char text[100];
      std::snprintf(text, sizeof text, " (%.3g %% of its largest, %.3g)", 100 * drift / scale,
                    scale);
      return std::string(text);
    };
    auto part = [&](const char* format, double drift, double scale) {
      char text[100];
      std::snprintf(text, sizeof text, format, drift);
      out += text + relative(drift, scale);
    };
    if (!linear_.empty()) {
      part(" momentum drift |P - P(0)| <= %.3g kg m/s", linear_drift_, linear_scale_);
      part(", |L - L(0)| <= %.3g kg m^2/s", angular_drift_, angular_scale_);
    }
    if (!energy_.empty())
      part(linear_.empty() ? " energy drift |E - E(0)| <= %.3g J"
                           : "; energy drift |E - E(0)| <= %.3g J",
           energy_drift_, energy_scale_);
    return out + "\n";
  }

 private:
  std::vector<size_t> linear_, angular_, energy_;
  std::vector<double> first_;
  double linear_drift_ = 0, angular_drift_ = 0, energy_drift_ = 0;
  double linear_scale_ = 0, angular_scale_ = 0, energy_scale_ = 0;
};

// Progress on long runs: after 2 s of wall time, every 10 %.
class Progress {
 public:
  explicit Progress(double t_end) : t_end_(t_end) {}
  void at(double t) {
    const int percent = static_cast<int>(100 * t / t_end_);
    if (percent >= last_ + 10 && seconds() > 2) {
      last_ = percent - percent % 10;
      std::fprintf(stderr, "spacearm: simulated %d %% (t = %g s)\n", last_, t);
    }
  }
  double seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0_).count();
  }

 private:
  double t_end_;
  int last_ = 0;
  std::chrono::steady_clock::time_point wall0_ = std::chrono::steady_clock::now();
};

// The torque of a run that a stop request or --max-wall ends: checked at every evaluation.
struct StoppableTorque {
  const TorqueReplay<Eigen::Dynamic>* replay;
  const TorqueSignal<Eigen::Dynamic>* signal;
  Pace* pace;
  Eigen::VectorXd operator()(double t) const {
    check_stop();
    pace->at(t);
    return replay ? (*replay)(t) : (*signal)(t);
  }
  void evaluate(double t, Eigen::VectorXd& value) const {  // into value: no allocation
    check_stop();
    pace->at(t);
    replay ? replay->evaluate(t, value) : signal->evaluate(t, value);
  }
};

// Why a run past --max-wall was stopped, with the mode that sets its pace.
std::string too_slow_message(const TooSlow& slow, const SimulateArgs& a,
                             const IntegratorOptions& opt, const StiffestMode& mode) {
  char buf[700];
  std::snprintf(buf, sizeof buf,
                "simulate: at its pace the run would take about %.3g s of wall time (t = %.4g "
                "of %.4g s after %.3g s), past --max-wall %g s; %s at the start: %s. Raise "
                "--max-wall, shorten --t-end, or soften that mode (a stiffer spring needs "
                "smaller steps)",
                slow.projected_s, slow.t, a.t_end, slow.elapsed_s, a.max_wall,
                to_string(opt.method).c_str(), describe(mode).c_str());
  return buf;
}

// The run itself, once the scene's model is loaded and the options are read.
int simulate_loaded(const SimulateArgs& a, const ModelRecipe& scene, const CompiledModel& compiled,
                    const Eigen::VectorXd& params, Eigen::VectorXd q0, Eigen::VectorXd qd0,
                    PlanSamples* plan, const TorqueTable* torque_file, double dt_out) {
  const ModelFacts& facts = scene.facts();
  const bool passive = facts.has_passive_forces();
  const int N = facts.dims.num_links;
  const DynamicModel model = dynamic_model(compiled, params);
  if (plan) {
    prepare_replay(a, model, *plan, q0, qd0);
    // The torques it applies and the plan's rates against the URDF's joint limits.
    cli::report_limit_use(cli::limit_use(scene, plan->torques.samples, plan->rates, plan->angles));
  }
  const auto tau = torque_signal(a, N, plan ? &plan->torques : torque_file);
  if (a.consistent_start) consistent_start(model, q0, qd0, (*tau)(0.0));
  // The integrator, from the stiffest mode at the start.
  const StiffestMode mode = stiffest_mode(model, q0, qd0, model.generalized_forces((*tau)(0.0)));
  IntegratorOptions opt = integrator_options(a, mode, model.has_state_jacobian(), dt_out);
  check_output_grid(a, dt_out, opt, [&] { return compiled.span_note(params); });
  // From a file: steps land on the samples, and a held torque is a true zero-order hold.
  std::unique_ptr<TorqueReplay<Eigen::Dynamic>> replay;
  if (!a.zero_torque) replay = std::make_unique<TorqueReplay<Eigen::Dynamic>>(*tau, opt, "--dt");
  const SimulationTable table(model, facts.geared);

  // Opened only now: a run refused above leaves an existing output file untouched.
  auto inputs = cli::scene_inputs(a.scene_path, scene);
  inputs.insert(inputs.end(), {{"--torques", a.torque_file}, {"--plan", a.plan_file}});
  refuse_input_as_output(a.output_file, inputs);
  RowWriter out(a.output_file);
  const std::string head = header(table);
  warn_if_large(a, dt_out, static_cast<int>(std::count(head.begin(), head.end(), ',')) + 1);
  out.row(head);

  // The library's integrate_motion; a stop request is seen at every evaluation and sample.
  Pace pace(a.t_end, a.max_wall);
  const StoppableTorque torque{replay.get(), tau.get(), &pace};
  Progress progress(a.t_end);
  double t_written = 0;
  std::vector<double> values;
  // Energy is conserved only where nothing drives the arm and nothing dissipates.
  Invariants invariants(table.names(), model, a.zero_torque && !passive);
  auto observe = [&](double t, const Eigen::VectorXd& q, const Eigen::VectorXd& qd) {
    table.row(t, q, qd, (*tau)(t), values);
    out.row(row(values));
    invariants.row(values);
    t_written = t;
    check_stop();
    progress.at(t);
  };
  // What made the CSV, beside it, once it is closed (whole, or cut short by a stop).
  const auto close = [&] {
    out.close();
    cli::write_provenance(a.output_file, cli::run_provenance(a.command_line, a.scene_path,
                                                             facts.parameter_names, params));
  };
  const cli::StopOnSignals signals;
  try {
    const auto stats = integrate_motion(model, q0, qd0, torque, a.t_end, dt_out, opt, observe);
    close();
    std::fputs(invariants.report().c_str(), stderr);
    if (a.verbose)
      std::fprintf(stderr,
                   "spacearm: run %.1f ms, %ld right-hand-side evaluations, %llu bytes written\n",
                   1e3 * progress.seconds(), stats.rhs_evaluations, out.bytes());
    return 0;
  } catch (const Interrupted& i) {
    close();
    report_stop(out, t_written, "interrupted by " + cli::signal_name(i.signal));
    return 128 + i.signal;
  } catch (const TooSlow& slow) {
    close();
    report_stop(out, t_written, "stopped: too slow for --max-wall");
    throw std::invalid_argument(too_slow_message(slow, a, opt, mode));
  } catch (const IntegrationError& e) {
    close();  // what was computed so far stays in the CSV
    report_stop(out, t_written, "the integration stopped");
    throw IntegrationError(failure_advice(e, opt, mode), e.t(), e.state());
  } catch (const OutputError&) {
    throw;  // the CSV itself failed: nothing more can be written to it
  } catch (const std::exception&) {
    // Any other failure still keeps every row computed (the buffer flushed, the file closed).
    close();
    report_stop(out, t_written, "the run stopped");
    throw;
  }
}

}  // namespace

int run_simulate(const SimulateArgs& args) {
  // Everything the run needs is checked before the output file is opened.
  SimulateArgs a = args;
  const ModelRecipe scene = cli::load_scene(a.scene_path);
  const ModelFacts& facts = scene.facts();
  const bool passive = facts.has_passive_forces();
  const auto wants = [&facts](Output o) {
    return std::count(facts.outputs.begin(), facts.outputs.end(), o) != 0;
  };
  if (!has_forward_dynamics(wants, passive))
    throw std::invalid_argument(
        passive ? "simulate: a scene with springs, dampers or friction must emit forward_dynamics "
                  "(field 'outputs')"
                : "simulate: the scene must emit forward_dynamics, or mass_matrix and bias_forces "
                  "(field 'outputs')");
  const int nq = facts.dims.nq, nv = facts.dims.nv, N = facts.dims.num_links;
  if (a.consistent_start && !(facts.features & needs::springs))
    throw std::invalid_argument(
        "--consistent-start: the scene has no flexible joint (gears[i].stiffness)");
  // Default: at rest, the base's quaternion the identity.
  Eigen::VectorXd q0 = a.q0_text.empty()
                           ? ConfigurationSpace{nq, nv, facts.quaternion_offset}.neutral()
                           : cli::parse_vector(a.q0_text, "--q0", nq);
  if (const std::string e = ConfigurationSpace::angle_error(
          q0, ConfigurationSpace::first_angle(facts.free_floating, facts.dims.spatial), "--q0",
          facts.coordinate_names);
      !e.empty())
    throw std::invalid_argument(e);
  Eigen::VectorXd qd0 =
      a.qd0_text.empty() ? Eigen::VectorXd::Zero(nv) : cli::parse_vector(a.qd0_text, "--qd0", nv);
  const Eigen::VectorXd params = cli::parse_parameters(a.param_assignments, facts);
  // The samples: a plan's (its end is the default --t-end), a torque file's, or none.
  std::optional<PlanSamples> plan;
  std::optional<TorqueTable> torque_file;
  if (!a.plan_file.empty()) {
    plan = read_plan_csv(read_text_file(a.plan_file, "--plan"), N, facts.free_floating, a.plan_file,
                         facts.dims.spatial);
    if (a.t_end == 0) a.t_end = plan->torques.t_last();
  } else if (!a.zero_torque) {
    torque_file = read_torque_csv(read_text_file(a.torque_file, "--torques"), N, a.torque_file);
  }
  if (!(a.t_end > 0))
    throw std::invalid_argument("--t-end: required without --plan (the end time, s)");
  const double dt_out = a.dt_out > 0 ? a.dt_out : a.dt;
  const CompiledModel compiled = load_model(a, scene);
  // A failure at parameters beyond the span the generator checked names that span.
  const int status = with_span_note(
      [&] { return compiled.span_note(params); },
      [&] {
        return simulate_loaded(a, scene, compiled, params, q0, qd0, plan ? &*plan : nullptr,
                               torque_file ? &*torque_file : nullptr, dt_out);
      });
  if (a.verbose) std::fprintf(stderr, "spacearm: %s\n", compiled.engine_report().c_str());
  return status;
}

}  // namespace spacearm
