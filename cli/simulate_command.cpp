#include "simulate_command.hpp"

#include <algorithm>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

#include "cli_input.hpp"
#include "compiled_model.hpp"
#include "dynamic_model.hpp"
#include "consistent_start.hpp"
#include "integrators.hpp"
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

std::string read_text_file(const std::string& path, const std::string& option) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::invalid_argument(option + ": cannot open '" + path + "'");
  std::ostringstream s;
  s << in.rdbuf();
  if (in.bad()) throw std::invalid_argument(option + ": cannot read '" + path + "'");
  return s.str();
}

// The torque signal of the run: from the CSV (which must cover [0, t_end] unless asked to
// extrapolate), or zero.
std::unique_ptr<TorqueSignal<Eigen::Dynamic>> torque_signal(const SimulateArgs& a, int N) {
  const Interpolation mode = interpolation_from_string(a.interpolation);
  const Extrapolation outside = extrapolation_from_string(a.extrapolate);
  if (a.zero_torque) {
    const std::vector<Eigen::VectorXd> zero{Eigen::VectorXd::Zero(N), Eigen::VectorXd::Zero(N)};
    return std::make_unique<TorqueSignal<Eigen::Dynamic>>(0.0, a.t_end, zero,
                                                          Interpolation::linear);
  }
  const TorqueTable table =
      read_torque_csv(read_text_file(a.torque_file, "--torques"), N, a.torque_file);
  const std::string gap = coverage_gap(table.t0, table.t_last(), a.t_end);
  if (outside == Extrapolation::error && !gap.empty())
    throw std::invalid_argument("--torques '" + a.torque_file + "' covers " + gap +
                                ": give a file that covers it, or --extrapolate hold or "
                                "--extrapolate zero");
  return std::make_unique<TorqueSignal<Eigen::Dynamic>>(table.t0, table.dt, table.samples, mode,
                                                        outside);
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

// Says so before a run whose CSV would pass 1 GB.
void warn_if_large(const SimulateArgs& a, double dt_out, int columns) {
  const double rows = a.t_end / dt_out + 1, bytes = rows * columns * 24.0;
  if (bytes > 1e9)
    std::fprintf(stderr,
                 "spacearm: note: the output will be about %.3g GB (%.3g rows of %d columns); "
                 "a larger --dt-out thins it\n",
                 bytes / 1e9, rows, columns);
}

// What was written when the run stopped early, on stderr.
void report_stop(const RowWriter& out, double t_reached, const std::string& why) {
  std::fprintf(stderr, "spacearm: %s; %s holds every row up to t = %.17g s\n", why.c_str(),
               out.where().c_str(), t_reached);
}

IntegratorOptions integrator_options(const SimulateArgs& a) {
  IntegratorOptions opt;
  opt.method = method_from_string(a.integrator);
  opt.dt = a.dt;
  opt.rtol = a.rtol;
  opt.atol = a.atol;
  return opt;
}

// The scene's model, compiled or from the cache, with the stages reported under --verbose.
CompiledModel load_model(const SimulateArgs& a, const Scene& scene) {
  CompileOptions options;
  options.cache_dir = a.cache_dir;
  options.progress = [&](const std::string& m) {
    if (a.verbose || m.rfind("compiling", 0) == 0)
      std::fprintf(stderr, "spacearm: %s\n", m.c_str());
  };
  StageReport rep;
  CompiledModel model = CompiledModel::load(scene, options, &rep);
  if (a.verbose)
    std::fprintf(
        stderr,
        "spacearm: cache %s (%s); derive %.1f ms, emit %.1f ms, compile %.1f ms, load %.1f ms\n",
        rep.cache_entry.c_str(), rep.compiled ? "built" : "hit", rep.derive_ms, rep.emit_ms,
        rep.compile_ms, rep.load_ms);
  return model;
}

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

}  // namespace

int run_simulate(const SimulateArgs& a) {
  // Everything the run needs is checked before the output file is opened.
  const Scene scene = load_scene(a.scene_path);
  const bool passive = (scene.features() & (needs::springs | needs::friction)) != 0;
  if (!scene.wants(Output::forward_dynamics) &&
      (passive || !(scene.wants(Output::mass_matrix) && scene.wants(Output::bias_forces))))
    throw std::invalid_argument(
        passive ? "simulate: a scene with springs, dampers or friction must emit forward_dynamics "
                  "(field 'outputs')"
                : "simulate: the scene must emit forward_dynamics, or mass_matrix and bias_forces "
                  "(field 'outputs')");
  const int nq = scene.num_coordinates(), nv = scene.num_velocities(), N = scene.num_links();
  if (a.consistent_start && !scene.num_flexible())
    throw std::invalid_argument(
        "--consistent-start: the scene has no flexible joint (gears[i].stiffness)");
  Eigen::VectorXd q0 =
      a.q0_text.empty() ? Eigen::VectorXd::Zero(nq) : cli::parse_vector(a.q0_text, "--q0", nq);
  Eigen::VectorXd qd0 =
      a.qd0_text.empty() ? Eigen::VectorXd::Zero(nv) : cli::parse_vector(a.qd0_text, "--qd0", nv);
  const Eigen::VectorXd params = cli::parse_parameters(a.param_assignments, scene);
  IntegratorOptions opt = integrator_options(a);
  const double dt_out = a.dt_out > 0 ? a.dt_out : a.dt;
  const auto tau = torque_signal(a, N);
  // From a file: steps land on the samples, and a held torque is a true zero-order hold.
  std::unique_ptr<TorqueReplay<Eigen::Dynamic>> replay;
  if (!a.zero_torque) replay = std::make_unique<TorqueReplay<Eigen::Dynamic>>(*tau, opt, "--dt");
  const CompiledModel compiled = load_model(a, scene);
  const DynamicModel model = dynamic_model(compiled, params);
  if (a.consistent_start) consistent_start(model, q0, qd0, (*tau)(0.0));
  const SimulationTable table(model, scene.geared());

  // Opened only now: a run refused above leaves an existing output file untouched.
  refuse_input_as_output(a.output_file,
                         {{"the scene", a.scene_path}, {"--torques", a.torque_file}});
  RowWriter out(a.output_file);
  const std::string head = header(table);
  warn_if_large(a, dt_out, static_cast<int>(std::count(head.begin(), head.end(), ',')) + 1);
  out.row(head);

  // The library's integrate_motion; a stop request is seen at every evaluation and sample.
  auto torque = [&](double t) -> Eigen::VectorXd {
    check_stop();
    return replay ? (*replay)(t) : (*tau)(t);
  };
  Progress progress(a.t_end);
  double t_written = 0;
  std::vector<double> values;
  auto observe = [&](double t, const Eigen::VectorXd& q, const Eigen::VectorXd& qd) {
    table.row(t, q, qd, (*tau)(t), values);
    out.row(row(values));
    t_written = t;
    check_stop();
    progress.at(t);
  };
  const cli::StopOnSignals signals;
  try {
    const auto stats = integrate_motion(model, q0, qd0, torque, a.t_end, dt_out, opt, observe);
    out.close();
    if (a.verbose)
      std::fprintf(stderr,
                   "spacearm: run %.1f ms, %ld right-hand-side evaluations, %llu bytes written\n",
                   1e3 * progress.seconds(), stats.rhs_evaluations, out.bytes());
    return 0;
  } catch (const Interrupted& i) {
    out.close();
    report_stop(out, t_written,
                std::string("interrupted by ") + (i.signal == SIGINT ? "SIGINT" : "SIGTERM"));
    return 128 + i.signal;
  } catch (const IntegrationError& e) {
    out.close();  // what was computed so far stays in the CSV
    report_stop(out, t_written, "the integration stopped");
    throw;
  }
}

}  // namespace spacearm
