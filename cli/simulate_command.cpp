#include "simulate_command.hpp"

#include <Eigen/Cholesky>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

#include "cli_input.hpp"
#include "compiled_model.hpp"
#include "integrators.hpp"
#include "row_writer.hpp"
#include "simulation.hpp"
#include "torque_csv.hpp"
#include "torque_signal.hpp"

namespace spacearm {

namespace {

volatile std::sig_atomic_t g_stop = 0;
void request_stop(int sig) { g_stop = sig; }

// Thrown from the observer or the right-hand side when a stop was requested. Not a
// runtime_error, so that integrate() passes it on instead of reporting a failed step.
struct Interrupted {
  int signal;
};

// SIGINT/SIGTERM handlers for the lifetime of the run.
class StopOnSignals {
 public:
  StopOnSignals() {
    g_stop = 0;
    struct sigaction sa {};
    sa.sa_handler = request_stop;
    sigemptyset(&sa.sa_mask);
    // A signal the caller ignores (a background job's SIGINT) stays ignored.
    sigaction(SIGINT, nullptr, &old_int_);
    sigaction(SIGTERM, nullptr, &old_term_);
    if (old_int_.sa_handler != SIG_IGN) sigaction(SIGINT, &sa, nullptr);
    if (old_term_.sa_handler != SIG_IGN) sigaction(SIGTERM, &sa, nullptr);
  }
  ~StopOnSignals() {
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
  }
  static void check() {
    if (g_stop) throw Interrupted{g_stop};
  }

 private:
  struct sigaction old_int_ {
  }, old_term_{};
};

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
  const double tol = 1e-9 * std::max(1.0, a.t_end);
  if (outside == Extrapolation::error && (table.t0 > tol || table.t_last() < a.t_end - tol))
    throw std::invalid_argument(
        "--torques '" + a.torque_file + "' covers t = " + std::to_string(table.t0) + " .. " +
        std::to_string(table.t_last()) + " s, the run needs 0 .. " + std::to_string(a.t_end) +
        " s: give a file that covers it, or --extrapolate hold or --extrapolate zero");
  return std::make_unique<TorqueSignal<Eigen::Dynamic>>(table.t0, table.dt, table.samples, mode,
                                                        outside);
}

struct Columns {
  bool geared, pose, energy, momentum;
};

std::string header(const CompiledModel& model, const Columns& c) {
  std::string h = "t";
  for (const auto& n : model.coordinate_names()) h += "," + n;
  for (const auto& n : model.coordinate_names()) h += "," + n + "d";
  const int N = model.num_links();
  // Geared: link-side angles q = qm / p and rates next to the motor coordinates.
  if (c.geared) {
    for (int j = 1; j <= N; ++j) h += ",q" + std::to_string(j);
    for (int j = 1; j <= N; ++j) h += ",q" + std::to_string(j) + "d";
  }
  // The applied torque, named by its side: tau on the link (gear output), tau/p at the motor.
  for (int j = 1; j <= N; ++j) h += ",tau" + std::to_string(j);
  if (c.geared)
    for (int j = 1; j <= N; ++j) h += ",tau_motor" + std::to_string(j);
  if (c.pose) h += ",ee_x,ee_y,ee_phi";
  if (c.energy) h += ",kinetic_energy";
  if (c.momentum) h += ",Px,Py,L";
  return h + "\n";
}

void append(std::string& row, double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, ",%.17g", v);
  row += buf;
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

}  // namespace

int run_simulate(const SimulateArgs& a) {
  const Scene scene = load_scene(a.scene_path);
  if (!scene.wants(Output::forward_dynamics) &&
      !(scene.wants(Output::mass_matrix) && scene.wants(Output::bias_forces)))
    throw std::invalid_argument(
        "simulate: the scene must emit forward_dynamics, or mass_matrix and bias_forces (field "
        "'outputs')");
  const int nq = scene.num_coordinates(), nv = scene.num_velocities(), N = scene.num_links();
  const Eigen::VectorXd q0 =
      a.q0_text.empty() ? Eigen::VectorXd::Zero(nq) : cli::parse_vector(a.q0_text, "--q0", nq);
  const Eigen::VectorXd qd0 =
      a.qd0_text.empty() ? Eigen::VectorXd::Zero(nv) : cli::parse_vector(a.qd0_text, "--qd0", nv);
  const Eigen::VectorXd params = cli::parse_parameters(a.param_assignments, scene);
  IntegratorOptions opt;
  opt.method = method_from_string(a.integrator);
  opt.dt = a.dt;
  opt.rtol = a.rtol;
  opt.atol = a.atol;
  const double dt_out = a.dt_out > 0 ? a.dt_out : a.dt;
  const auto tau = torque_signal(a, N);
  // From a file: steps land on the samples, and a held torque is a true zero-order hold.
  std::unique_ptr<TorqueReplay<Eigen::Dynamic>> replay;
  if (!a.zero_torque) replay = std::make_unique<TorqueReplay<Eigen::Dynamic>>(*tau, opt, "--dt");
  CompileOptions options;
  options.cache_dir = a.cache_dir;
  options.progress = [&](const std::string& m) {
    if (a.verbose || m.rfind("compiling", 0) == 0)
      std::fprintf(stderr, "spacearm: %s\n", m.c_str());
  };
  StageReport rep;
  const auto model = CompiledModel::load(scene, options, &rep);
  if (a.verbose)
    std::fprintf(
        stderr,
        "spacearm: cache %s (%s); derive %.1f ms, emit %.1f ms, compile %.1f ms, load %.1f ms\n",
        rep.cache_entry.c_str(), rep.compiled ? "built" : "hit", rep.derive_ms, rep.emit_ms,
        rep.compile_ms, rep.load_ms);
  const Eigen::VectorXd ratios = model.gear_ratios(params);
  const Columns cols{scene.geared(), model.has(Output::end_effector_pose),
                     model.has(Output::kinetic_energy), model.has(Output::momentum)};
  // Opened only now: a run refused above leaves an existing output file untouched.
  refuse_input_as_output(a.output_file,
                         {{"the scene", a.scene_path}, {"--torques", a.torque_file}});
  RowWriter out(a.output_file);
  const std::string head = header(model, cols);
  warn_if_large(a, dt_out, static_cast<int>(std::count(head.begin(), head.end(), ',')) + 1);
  out.row(head);

  auto torque_at = [&](double t) -> Eigen::VectorXd { return replay ? (*replay)(t) : (*tau)(t); };
  using State = Eigen::VectorXd;
  auto f = [&](const State& x, State& dxdt, double t) {
    StopOnSignals::check();
    const Eigen::VectorXd q = x.head(nq), qd = x.tail(nv);
    dxdt.resize(nq + nv);
    dxdt.head(nq) = qd;  // dq/dt = qd: nq == nv for every planar model (Model::configuration_rate)
    if (!x.allFinite()) throw std::runtime_error("state not finite at t = " + std::to_string(t));
    Eigen::VectorXd Q = Eigen::VectorXd::Zero(nv);
    Q.tail(N) = torque_at(t).cwiseQuotient(ratios);  // eq. 14
    try {
      dxdt.tail(nv) = model.forward_dynamics(q, qd, Q, params);
    } catch (const DynamicsError& e) {
      throw DynamicsError(std::string(e.what()) + " at t = " + std::to_string(t));
    }
  };
  const auto wall0 = std::chrono::steady_clock::now();
  int last_percent = 0;
  double t_written = 0;
  auto observe = [&](const State& x, double t) {
    const Eigen::VectorXd q = x.head(nq), qd = x.tail(nv);
    const Eigen::VectorXd tau_t = (*tau)(t);
    std::string row;
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.17g", t);
    row += buf;
    for (int i = 0; i < nq + nv; ++i) append(row, x[i]);
    if (cols.geared) {
      for (int j = 0; j < N; ++j) append(row, q[nq - N + j] / ratios[j]);
      for (int j = 0; j < N; ++j) append(row, qd[nv - N + j] / ratios[j]);
    }
    for (int j = 0; j < N; ++j) append(row, tau_t[j]);
    if (cols.geared)
      for (int j = 0; j < N; ++j) append(row, tau_t[j] / ratios[j]);
    if (cols.pose)
      for (double v : model.end_effector_pose(q, params)) append(row, v);
    if (cols.energy) append(row, model.kinetic_energy(q, qd, params));
    if (cols.momentum)
      for (double v : model.momentum(q, qd, params)) append(row, v);
    out.row(row + "\n");
    t_written = t;
    StopOnSignals::check();
    // Progress on long runs (after 2 s of wall time, every 10 %).
    const int percent = static_cast<int>(100 * t / a.t_end);
    if (percent >= last_percent + 10 &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count() > 2) {
      last_percent = percent - percent % 10;
      std::fprintf(stderr, "spacearm: simulated %d %% (t = %g s)\n", last_percent, t);
    }
  };
  State x(nq + nv);
  x << q0, qd0;
  const StopOnSignals signals;
  try {
    const auto stats = integrate(opt, f, x, 0.0, a.t_end, dt_out, observe);
    out.close();
    if (a.verbose)
      std::fprintf(
          stderr, "spacearm: run %.1f ms, %ld right-hand-side evaluations, %llu bytes written\n",
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - wall0)
              .count(),
          stats.rhs_evaluations, out.bytes());
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
