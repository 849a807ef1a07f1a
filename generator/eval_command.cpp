#include "eval_command.hpp"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>

#include "cli_input.hpp"
#include "compiled_model.hpp"
#include "symbolic_model.hpp"

namespace spacearm {

namespace {

using clock = std::chrono::steady_clock;

double ms_since(clock::time_point t0) { return std::chrono::duration<double, std::milli>(clock::now() - t0).count(); }

// A result as JSON: a number (1 x 1), a list (a column) or a list of rows. Every entry must
// be finite, else an error naming the output and the entry (an overflow must not reach the
// JSON as null).
nlohmann::ordered_json to_json(const std::string& name, const Eigen::MatrixXd& m) {
  for (Eigen::Index i = 0; i < m.rows(); ++i)
    for (Eigen::Index j = 0; j < m.cols(); ++j)
      if (!std::isfinite(m(i, j)))
        throw std::runtime_error(name + "[" + std::to_string(i) + "]" + (m.cols() > 1 ? "[" + std::to_string(j) + "]" : "") +
                                 " is not finite (" + std::to_string(m(i, j)) + "): the state or parameters overflow");
  if (m.size() == 1) return m(0, 0);
  if (m.cols() == 1) return std::vector<double>(m.data(), m.data() + m.size());
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    nlohmann::ordered_json row = nlohmann::ordered_json::array();
    for (Eigen::Index j = 0; j < m.cols(); ++j) row.push_back(m(i, j));
    rows.push_back(row);
  }
  return rows;
}

// The inputs an output takes, from the state.
std::vector<Eigen::VectorXd> inputs_of(const OutputInfo& o, const Eigen::VectorXd& q, const Eigen::VectorXd& qd) {
  std::vector<Eigen::VectorXd> in;
  for (Input i : o.inputs) in.push_back(i == Input::q ? q : qd);
  return in;
}

// GiNaC's value of each output the scene emits.
void evaluate_symbolic(const Scene& scene, const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                       const Eigen::VectorXd& params, bool verbose, nlohmann::ordered_json& out) {
  auto t0 = clock::now();
  const SymbolicModel model = derive(scene);
  if (verbose) std::fprintf(stderr, "spacearm: derive %.1f ms\n", ms_since(t0));
  t0 = clock::now();
  const std::vector<double> qv(q.data(), q.data() + q.size()), qdv(qd.data(), qd.data() + qd.size()),
      pv(params.data(), params.data() + params.size());
  for (const auto& o : output_registry()) {
    if (!scene.wants(o.id)) continue;
    const GiNaC::matrix& e = model.expression(o.id);
    const auto values = evaluate(model, e, qv, qdv, pv);
    const Eigen::MatrixXd m = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
        values.data(), e.rows(), e.cols());
    out[o.name] = to_json(o.name, m);
  }
  if (verbose) std::fprintf(stderr, "spacearm: evaluate (GiNaC) %.1f ms\n", ms_since(t0));
}

// The compiled model's value of each output the scene emits.
void evaluate_compiled(const Scene& scene, const EvalArgs& a, const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                       const Eigen::VectorXd& params, nlohmann::ordered_json& out) {
  CompileOptions options;
  options.cache_dir = a.cache_dir;
  options.progress = [verbose = a.verbose](const std::string& m) {
    if (verbose || m.rfind("compiling", 0) == 0 || m.rfind("deriving", 0) == 0)
      std::fprintf(stderr, "spacearm: %s%s\n", m.c_str(), verbose ? "" : " ...");
  };
  StageReport rep;
  const auto model = CompiledModel::load(scene, options, &rep);
  if (a.verbose)
    std::fprintf(stderr, "spacearm: cache %s (%s)\nspacearm: derive %.1f ms, emit %.1f ms, compile %.1f ms, load %.1f ms\n",
                 rep.cache_entry.c_str(), rep.compiled ? "built" : "hit", rep.derive_ms, rep.emit_ms, rep.compile_ms,
                 rep.load_ms);
  const auto t0 = clock::now();
  for (const auto& o : output_registry())
    if (model.has(o.id)) out[o.name] = to_json(o.name, model.evaluate(o.id, inputs_of(o, q, qd), params)[0]);
  if (a.verbose) std::fprintf(stderr, "spacearm: run %.3f ms\n", ms_since(t0));
}

}  // namespace

int run_eval(const EvalArgs& a) {
  const Scene scene = load_scene(a.scene_path);
  const int nq = scene.num_coordinates(), nv = scene.num_coordinates();
  const Eigen::VectorXd q = cli::parse_vector(a.q_text, "--q", nq);
  const Eigen::VectorXd qd = a.qd_text.empty() ? Eigen::VectorXd::Zero(nv) : cli::parse_vector(a.qd_text, "--qd", nv);
  const Eigen::VectorXd params = cli::parse_parameters(a.param_assignments, scene);
  // The state and parameters used, then every output by its registry name.
  nlohmann::ordered_json out;
  out["coordinates"] = scene.coordinate_names();
  out["q"] = std::vector<double>(q.data(), q.data() + nq);
  out["qd"] = std::vector<double>(qd.data(), qd.data() + nv);
  out["parameters"] = nlohmann::ordered_json::object();
  for (size_t i = 0; i < scene.parameters.size(); ++i) out["parameters"][scene.parameters[i].name] = params[i];
  if (a.symbolic)
    evaluate_symbolic(scene, q, qd, params, a.verbose, out);
  else
    evaluate_compiled(scene, a, q, qd, params, out);
  std::cout << (a.compact_json ? out.dump() : out.dump(2)) << "\n";
  return 0;
}

}  // namespace spacearm
