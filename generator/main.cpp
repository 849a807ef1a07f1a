// spacearm: command-line front end of the generator.
//   spacearm generate SCENE -o DIR [--stats]   emit optimized C++ for a scene
//   spacearm inspect SCENE ENTRY [--latex]     print one symbolic entry, e.g. M[3][4]
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>

#include "compiled_model.hpp"
#include "integrators.hpp"
#include "torque_signal.hpp"
#include <Eigen/Cholesky>
#include <fstream>
#include "cpp_emitter.hpp"
#include "scene.hpp"
#include "symbolic_model.hpp"

namespace {

void print_stats(const spacearm::EmittedModel& emitted, std::ostream& out) {
  out << "function                 basis   adds   muls   divs  total  sin/cos\n";
  for (const auto& f : emitted.stats) {
    char line[160];
    std::snprintf(line, sizeof line, "%-24s %-6s %5d  %5d  %5d  %5d  %7d\n", f.name.c_str(),
                  f.velocity_basis.empty() ? "-" : f.velocity_basis.c_str(), f.ops.adds, f.ops.muls, f.ops.divs,
                  f.ops.total_arithmetic(), f.ops.trig);
    out << line;
  }
}

// Parses "a,b,c" for option `name` into exactly n finite numbers.
Eigen::VectorXd parse_vector(const std::string& text, const std::string& name, int n) {
  std::vector<double> values;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    char* end = nullptr;
    const double v = std::strtod(item.c_str(), &end);
    if (item.empty() || end == item.c_str() || *end != '\0')
      throw std::invalid_argument(name + "[" + std::to_string(values.size()) + "]: '" + item + "' is not a number");
    if (!std::isfinite(v))
      throw std::invalid_argument(name + "[" + std::to_string(values.size()) + "] is not finite: '" + item + "'");
    values.push_back(v);
  }
  if (static_cast<int>(values.size()) != n)
    throw std::invalid_argument(name + ": expected " + std::to_string(n) + " comma-separated values, got " +
                                std::to_string(values.size()));
  return Eigen::Map<Eigen::VectorXd>(values.data(), n);
}

// --param name=value pairs over the scene's nominal parameter values.
Eigen::VectorXd parse_parameters(const std::vector<std::string>& assignments, const spacearm::Scene& scene) {
  std::vector<std::string> names;
  Eigen::VectorXd p(static_cast<int>(scene.parameters.size()));
  for (const auto& param : scene.parameters) {
    p[static_cast<int>(names.size())] = param.nominal.value;
    names.push_back(param.name);
  }
  for (const auto& a : assignments) {
    const auto eq = a.find('=');
    if (eq == std::string::npos) throw std::invalid_argument("--param '" + a + "': expected name=value");
    const std::string name = a.substr(0, eq);
    const auto it = std::find(names.begin(), names.end(), name);
    if (it == names.end()) {
      std::string known;
      for (const auto& n : names) known += (known.empty() ? "" : ", ") + n;
      throw std::invalid_argument("--param: unknown parameter '" + name + "' (known: " + (known.empty() ? "none" : known) + ")");
    }
    p[it - names.begin()] = parse_vector(a.substr(eq + 1), "--param " + name, 1)[0];
  }
  return p;
}

nlohmann::json to_json(const Eigen::MatrixXd& m) {
  nlohmann::json rows = nlohmann::json::array();
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    nlohmann::json row = nlohmann::json::array();
    for (Eigen::Index j = 0; j < m.cols(); ++j) row.push_back(m(i, j));
    rows.push_back(row);
  }
  return rows;
}
nlohmann::json to_json(const Eigen::VectorXd& v) { return std::vector<double>(v.data(), v.data() + v.size()); }

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"spacearm: symbolic dynamics of free-floating space manipulators, emitted as C++"};
  app.require_subcommand(1);

  std::string scene_path, out_dir, entry;
  bool stats = false, latex = false, expanded = false;

  auto* generate = app.add_subcommand("generate", "Derive the model of a scene and emit C++ sources");
  generate->add_option("scene", scene_path, "Scene file (YAML)")->required();
  generate->add_option("-o,--output", out_dir, "Output folder")->required();
  generate->add_flag("--stats", stats, "Print adds, multiplies, divisions and sin/cos calls per function");
  bool check = false;
  std::string file_stem;
  generate->add_option("--file-stem", file_stem,
                       "Name the files STEM.hpp/STEM.cpp instead of after the scene (the namespace keeps the scene name)");
  bool plain = false;
  generate->add_flag("--plain", plain,
                     "Emit the benchmark baseline instead: expanded expressions without common-subexpression "
                     "elimination (namespace and files NAME_plain)");
  generate->add_flag("--check", check,
                     "Write nothing; exit 1 if the files in the output folder differ from what would be generated");

  auto* inspect = app.add_subcommand("inspect", "Print one symbolic entry of the derived model");
  inspect->add_option("scene", scene_path, "Scene file (YAML)")->required();
  inspect->add_option("entry", entry, "T, M[i][j], C[i][j], b[i], h[i] (momentum), x[i] (pose), J[i][j]")
      ->required();
  inspect->add_flag("--latex", latex, "Print LaTeX instead of plain text");
  inspect->add_flag("--decimal", expanded, "Show numeric coefficients as decimals instead of exact fractions");

  auto* eval = app.add_subcommand("eval", "Evaluate a scene's quantities at a state (compiled and cached, or --symbolic)");
  std::string q_text, qd_text, cache_dir;
  std::vector<std::string> param_assignments;
  bool json = false, symbolic = false, verbose = false;
  eval->add_option("scene", scene_path, "Scene file (YAML)")->required();
  eval->add_option("--q", q_text, "Coordinates, comma-separated")->required();
  eval->add_option("--qd", qd_text, "Velocities, comma-separated (default: zeros)");
  eval->add_option("--param", param_assignments, "Run-time parameter name=value (repeatable)");
  eval->add_flag("--json", json, "Compact JSON on one line (default: indented JSON)");
  eval->add_flag("--symbolic", symbolic, "Evaluate GiNaC's expressions instead of the compiled code");
  eval->add_flag("--verbose", verbose, "Report the time of each stage on stderr");
  eval->add_option("--cache-dir", cache_dir, "Cache folder for compiled models");

  auto* simulate = app.add_subcommand("simulate", "Integrate a scene's dynamics under joint torques and write CSV");
  std::string torque_file, integrator = "rk4", output_file, q0_text, qd0_text, interpolation = "linear";
  bool zero_torque = false;
  double t_end = 0, dt = 0.01, rtol = 1e-8, atol = 1e-10, dt_out = 0;
  simulate->add_option("scene", scene_path, "Scene file (YAML)")->required();
  auto* torques_opt = simulate->add_option("--torques", torque_file,
                                           "CSV of joint torques: header, then t,tau1..tauN on a uniform grid");
  simulate->add_flag("--zero", zero_torque, "No torques (free motion)")->excludes(torques_opt);
  simulate->add_option("--t-end", t_end, "End time [s]")->required()->check(CLI::PositiveNumber);
  simulate->add_option("--integrator", integrator, "rk4, dopri5, rkf78 or implicit_midpoint");
  simulate->add_option("--dt", dt, "Step of the fixed-step methods [s]")->check(CLI::PositiveNumber);
  simulate->add_option("--dt-out", dt_out, "Output interval [s] (default: --dt)")->check(CLI::PositiveNumber);
  simulate->add_option("--rtol", rtol, "Relative tolerance of the adaptive methods")->check(CLI::PositiveNumber);
  simulate->add_option("--atol", atol, "Absolute tolerance of the adaptive methods")->check(CLI::PositiveNumber);
  simulate->add_option("--q0", q0_text, "Initial coordinates (default: zeros)");
  simulate->add_option("--qd0", qd0_text, "Initial velocities (default: zeros)");
  simulate->add_option("--param", param_assignments, "Run-time parameter name=value (repeatable)");
  simulate->add_option("--interpolation", interpolation, "Torque between samples: linear or hold");
  simulate->add_option("-o,--output", output_file, "CSV output (default: standard output)");
  simulate->add_option("--cache-dir", cache_dir, "Cache folder for compiled models");
  simulate->add_flag("--verbose", verbose, "Report the time of each stage on stderr");

  CLI11_PARSE(app, argc, argv);

  if (*simulate) {
    try {
      if (!zero_torque && torque_file.empty()) throw std::invalid_argument("simulate: give --torques FILE or --zero");
      const spacearm::Scene scene = spacearm::load_scene(scene_path);
      using spacearm::Output;
      if (!scene.wants(Output::mass_matrix) || !scene.wants(Output::bias_forces))
        throw std::invalid_argument("simulate: the scene must emit mass_matrix and bias_forces (field 'outputs')");
      const int n = scene.num_coordinates(), N = scene.num_links();
      const Eigen::VectorXd q0 = q0_text.empty() ? Eigen::VectorXd::Zero(n) : parse_vector(q0_text, "--q0", n);
      const Eigen::VectorXd qd0 = qd0_text.empty() ? Eigen::VectorXd::Zero(n) : parse_vector(qd0_text, "--qd0", n);
      const Eigen::VectorXd params = parse_parameters(param_assignments, scene);
      spacearm::IntegratorOptions opt;
      opt.method = spacearm::method_from_string(integrator);
      opt.dt = dt;
      opt.rtol = rtol;
      opt.atol = atol;
      if (dt_out == 0) dt_out = dt;

      // Torques: a CSV on a uniform grid, held or interpolated.
      using Joint = Eigen::Matrix<double, Eigen::Dynamic, 1>;
      std::vector<Joint> samples{Joint::Zero(N)};
      double t0_samples = 0, dt_samples = t_end;
      if (!zero_torque) {
        std::ifstream in(torque_file);
        if (!in) throw std::invalid_argument("--torques: cannot open '" + torque_file + "'");
        std::string line;
        std::getline(in, line);  // header
        std::vector<double> times;
        samples.clear();
        for (int row = 2; std::getline(in, line); ++row) {
          if (line.empty()) continue;
          const long cols = std::count(line.begin(), line.end(), ',') + 1;
          if (cols != N + 1)
            throw std::invalid_argument("--torques '" + torque_file + "' line " + std::to_string(row) + ": expected " +
                                        std::to_string(N + 1) + " columns (t, tau1..tau" + std::to_string(N) +
                                        "), got " + std::to_string(cols));
          const Eigen::VectorXd v = parse_vector(line, "--torques line " + std::to_string(row), N + 1);
          times.push_back(v[0]);
          samples.push_back(v.tail(N));
        }
        if (times.size() < 2) throw std::invalid_argument("--torques '" + torque_file + "': needs at least two rows");
        t0_samples = times.front();
        dt_samples = times[1] - times[0];
        for (size_t k = 1; k < times.size(); ++k)
          if (!(std::abs(times[k] - times[k - 1] - dt_samples) <= 1e-9 * std::max(1.0, std::abs(times[k]))))
            throw std::invalid_argument("--torques '" + torque_file + "': time grid not uniform at row " +
                                        std::to_string(k + 2));
      }
      const spacearm::TorqueSignal<Eigen::Dynamic> tau(t0_samples, dt_samples, samples,
                                                       spacearm::interpolation_from_string(interpolation));
      // The torques change slope (linear) or jump (hold) at every sample: adaptive steps land
      // on the samples instead of straddling them (see IntegratorOptions::breakpoint_interval).
      if (!zero_torque && t0_samples == 0) opt.breakpoint_interval = dt_samples;

      spacearm::CompileOptions options;
      options.cache_dir = cache_dir;
      options.progress = [&](const std::string& m) {
        if (verbose || m.rfind("compiling", 0) == 0) std::fprintf(stderr, "spacearm: %s\n", m.c_str());
      };
      spacearm::StageReport rep;
      const auto model = spacearm::CompiledModel::load(scene, options, &rep);
      if (verbose)
        std::fprintf(stderr, "spacearm: cache %s (%s); derive %.1f ms, emit %.1f ms, compile %.1f ms, load %.1f ms\n",
                     rep.cache_entry.c_str(), rep.compiled ? "built" : "hit", rep.derive_ms, rep.emit_ms,
                     rep.compile_ms, rep.load_ms);
      const Eigen::VectorXd ratios = model.gear_ratios(params);

      std::ofstream file;
      if (!output_file.empty()) {
        file.open(output_file);
        if (!file) throw std::invalid_argument("-o: cannot write '" + output_file + "'");
      }
      std::ostream& out = output_file.empty() ? std::cout : file;
      out.precision(17);
      out << "t";
      for (const auto& c : model.coordinate_names()) out << "," << c;
      for (const auto& c : model.coordinate_names()) out << "," << c << "d";
      if (model.has(Output::end_effector_pose)) out << ",ee_x,ee_y,ee_phi";
      if (model.has(Output::kinetic_energy)) out << ",kinetic_energy";
      if (model.has(Output::momentum)) out << ",Px,Py,L";
      out << "\n";

      using State = Eigen::VectorXd;
      auto tau_of = [&](double t) {
        Eigen::VectorXd Q = Eigen::VectorXd::Zero(n);
        Q.tail(N) = tau(t).cwiseQuotient(ratios);  // eq. 14
        return Q;
      };
      auto f = [&](const State& x, State& dxdt, double t) {
        const Eigen::VectorXd q = x.head(n), qd = x.tail(n);
        dxdt.resize(2 * n);
        dxdt.head(n) = qd;
        if (!x.allFinite()) throw std::runtime_error("state not finite at t = " + std::to_string(t));
        Eigen::LLT<Eigen::MatrixXd> llt(model.mass_matrix(q, params));
        if (llt.info() != Eigen::Success)
          throw std::runtime_error("mass matrix not positive definite at t = " + std::to_string(t));
        dxdt.tail(n) = llt.solve(tau_of(t) - model.bias_forces(q, qd, params));
        if (!dxdt.allFinite())
          throw std::runtime_error("accelerations not finite (overflow) at t = " + std::to_string(t));
      };
      const auto wall0 = std::chrono::steady_clock::now();
      int last_percent = 0;
      auto observe = [&](const State& x, double t) {
        const Eigen::VectorXd q = x.head(n), qd = x.tail(n);
        out << t;
        for (int i = 0; i < 2 * n; ++i) out << "," << x[i];
        if (model.has(Output::end_effector_pose)) {
          const Eigen::Vector3d e = model.end_effector_pose(q, params);
          out << "," << e[0] << "," << e[1] << "," << e[2];
        }
        if (model.has(Output::kinetic_energy)) out << "," << model.kinetic_energy(q, qd, params);
        if (model.has(Output::momentum)) {
          const Eigen::Vector3d h = model.momentum(q, qd, params);
          out << "," << h[0] << "," << h[1] << "," << h[2];
        }
        out << "\n";
        // Progress on long runs (after 2 s of wall time, every 10 %).
        const int percent = static_cast<int>(100 * t / t_end);
        if (percent >= last_percent + 10 &&
            std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count() > 2) {
          last_percent = percent - percent % 10;
          std::fprintf(stderr, "spacearm: simulated %d %% (t = %g s)\n", last_percent, t);
        }
      };
      State x(2 * n);
      x << q0, qd0;
      try {
        const auto stats = spacearm::integrate(opt, f, x, 0.0, t_end, dt_out, observe);
        if (verbose)
          std::fprintf(stderr, "spacearm: run %.1f ms, %ld right-hand-side evaluations\n",
                       std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - wall0).count(),
                       stats.rhs_evaluations);
      } catch (...) {
        out.flush();  // what was computed so far stays in the CSV
        throw;
      }
      return 0;
    } catch (const std::exception& e) {
      std::cerr << "spacearm: error: " << e.what() << "\n";
      return 1;
    }
  }

  if (*eval) {
    try {
      using clock = std::chrono::steady_clock;
      auto t0 = clock::now();
      const spacearm::Scene scene = spacearm::load_scene(scene_path);
      const int n = scene.num_coordinates();
      const Eigen::VectorXd q = parse_vector(q_text, "--q", n);
      const Eigen::VectorXd qd = qd_text.empty() ? Eigen::VectorXd::Zero(n) : parse_vector(qd_text, "--qd", n);
      const Eigen::VectorXd params = parse_parameters(param_assignments, scene);
      nlohmann::json out;
      auto ms = [](auto a) { return std::chrono::duration<double, std::milli>(clock::now() - a).count(); };
      if (symbolic) {
        const spacearm::SymbolicModel model = spacearm::derive(scene);
        if (verbose) std::fprintf(stderr, "spacearm: derive %.1f ms\n", ms(t0));
        t0 = clock::now();
        const std::vector<double> qv(q.data(), q.data() + n), qdv(qd.data(), qd.data() + n),
            pv(params.data(), params.data() + params.size());
        auto mat = [&](const GiNaC::matrix& m) {
          const auto values = spacearm::evaluate(model, m, qv, qdv, pv);
          return Eigen::MatrixXd(Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
              values.data(), m.rows(), m.cols()));
        };
        using spacearm::Output;
        if (scene.wants(Output::mass_matrix)) out["M"] = to_json(mat(model.mass_matrix));
        if (scene.wants(Output::coriolis_matrix)) out["C"] = to_json(mat(model.coriolis_matrix));
        if (scene.wants(Output::bias_forces)) out["bias"] = to_json(Eigen::VectorXd(mat(model.bias_forces)));
        if (scene.wants(Output::kinetic_energy)) out["kinetic_energy"] = spacearm::evaluate(model, model.kinetic_energy, qv, qdv, pv);
        if (scene.wants(Output::momentum)) out["momentum"] = to_json(Eigen::VectorXd(mat(model.momentum)));
        if (scene.wants(Output::end_effector_pose))
          out["end_effector"] = to_json(Eigen::VectorXd(mat(model.end_effector_pose)));
        if (verbose) std::fprintf(stderr, "spacearm: evaluate (GiNaC) %.1f ms\n", ms(t0));
      } else {
        spacearm::CompileOptions options;
        options.cache_dir = cache_dir;
        options.progress = [](const std::string& m) { std::fprintf(stderr, "spacearm: %s\n", m.c_str()); };
        if (!verbose) options.progress = [](const std::string& m) {
          if (m.rfind("compiling", 0) == 0 || m.rfind("deriving", 0) == 0) std::fprintf(stderr, "spacearm: %s ...\n", m.c_str());
        };
        spacearm::StageReport rep;
        const auto model = spacearm::CompiledModel::load(scene, options, &rep);
        if (verbose)
          std::fprintf(stderr,
                       "spacearm: cache %s (%s)\nspacearm: derive %.1f ms, emit %.1f ms, compile %.1f ms, load %.1f ms\n",
                       rep.cache_entry.c_str(), rep.compiled ? "built" : "hit", rep.derive_ms, rep.emit_ms,
                       rep.compile_ms, rep.load_ms);
        t0 = clock::now();
        using spacearm::Output;
        if (model.has(Output::mass_matrix)) out["M"] = to_json(model.mass_matrix(q, params));
        if (model.has(Output::coriolis_matrix)) out["C"] = to_json(model.coriolis_matrix(q, qd, params));
        if (model.has(Output::bias_forces)) out["bias"] = to_json(model.bias_forces(q, qd, params));
        if (model.has(Output::kinetic_energy)) out["kinetic_energy"] = model.kinetic_energy(q, qd, params);
        if (model.has(Output::momentum)) out["momentum"] = to_json(Eigen::VectorXd(model.momentum(q, qd, params)));
        if (model.has(Output::end_effector_pose))
          out["end_effector"] = to_json(Eigen::VectorXd(model.end_effector_pose(q, params)));
        if (verbose) std::fprintf(stderr, "spacearm: run %.3f ms\n", ms(t0));
      }
      std::cout << (json ? out.dump() : out.dump(2)) << "\n";
      return 0;
    } catch (const std::exception& e) {
      std::cerr << "spacearm: error: " << e.what() << "\n";
      return 1;
    }
  }

  try {
    using clock = std::chrono::steady_clock;
    const auto t0 = clock::now();
    const spacearm::Scene scene = spacearm::load_scene(scene_path);
    if (*generate) {
      const spacearm::SymbolicModel model = spacearm::derive(scene);
      const auto t1 = clock::now();
      spacearm::EmitOptions options;
      options.scene_path = scene_path;
      options.command = "spacearm generate " + scene_path + " -o " + out_dir +
                        (file_stem.empty() ? "" : " --file-stem " + file_stem) + (plain ? " --plain" : "");
      options.file_stem = file_stem;
      options.plain = plain;
      const auto emitted = spacearm::emit_cpp(model, options);
      if (check) {
        const auto stale = spacearm::stale_files(emitted, out_dir);
        for (const auto& f : stale) std::cerr << "spacearm: stale generated file: " << f << "\n";
        if (!stale.empty()) {
          std::cerr << "spacearm: regenerate with: " << options.command << "\n";
          return 1;
        }
        std::cout << "up to date: " << out_dir << "/" << emitted.header_name << ", " << out_dir << "/"
                  << emitted.source_name << "\n";
        return 0;
      }
      spacearm::write_files(emitted, out_dir);
      const auto t2 = clock::now();
      auto ms = [](auto a, auto b) { return std::chrono::duration<double, std::milli>(b - a).count(); };
      std::cout << "wrote " << out_dir << "/" << emitted.header_name << " and " << out_dir << "/"
                << emitted.source_name << " (" << scene.num_coordinates() << " coordinates, "
                << scene.parameters.size() << " parameters)\n";
      if (stats) {
        print_stats(emitted, std::cout);
        std::printf("derive %.0f ms, emit %.0f ms\n", ms(t0, t1), ms(t1, t2));
      }
      return 0;
    }
    spacearm::DeriveOptions options;
    options.all_outputs = true;
    const spacearm::SymbolicModel model = spacearm::derive(scene, options);
    GiNaC::ex e = spacearm::symbolic_entry(model, entry);
    // Group by velocities and run-time parameters, so that p, p^2 and p_i p_j stand out.
    GiNaC::lst group_by;
    for (const auto& v : model.qd) group_by.append(v);
    for (const auto& p : model.parameters) group_by.append(p);
    if (expanded) e = GiNaC::evalf(e);
    e = GiNaC::collect(e, group_by, true);
    if (latex)
      std::cout << GiNaC::latex << e << GiNaC::dflt << "\n";
    else
      std::cout << e << "\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "spacearm: error: " << e.what() << "\n";
    return 1;
  }
}
