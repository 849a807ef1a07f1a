#include "eval_command.hpp"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <optional>
#include <set>
#include <tuple>

#include "cli_input.hpp"
#include "compiled_model.hpp"
#include "span_note.hpp"
#include "dynamics_checks.hpp"
#include "state_conventions.hpp"

namespace spacearm {

namespace {

using clock = std::chrono::steady_clock;

double ms_since(clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(clock::now() - t0).count();
}

// A result as JSON: a number (1 x 1), a list (a column) or a list of rows. Every entry must
// be finite, else an error naming the output and the entry (an overflow must not reach the
// JSON as null).
nlohmann::ordered_json to_json(const std::string& name, const Eigen::MatrixXd& m) {
  for (Eigen::Index i = 0; i < m.rows(); ++i)
    for (Eigen::Index j = 0; j < m.cols(); ++j)
      if (!std::isfinite(m(i, j)))
        throw std::runtime_error(name + "[" + std::to_string(i) + "]" +
                                 (m.cols() > 1 ? "[" + std::to_string(j) + "]" : "") +
                                 " is not finite (" + std::to_string(m(i, j)) +
                                 "): the state or parameters overflow");
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

// An output's results: the value alone, or {name: value, ...} when it has several (the
// pivots of forward_dynamics, the base acceleration of free_base_inverse_dynamics).
// forward_dynamics passes the runtime's checks first: no meaningless accelerations.
nlohmann::ordered_json results_json(const std::string& model, const OutputInfo& o,
                                    const std::vector<Eigen::MatrixXd>& r) {
  if (o.id == Output::forward_dynamics) check_forward_dynamics(r, model);
  if (r.size() == 1) return to_json(o.name, r[0]);
  nlohmann::ordered_json all;
  for (size_t k = 0; k < r.size(); ++k)
    all[o.results[k].name] = to_json(std::string(o.name) + "." + o.results[k].name, r[k]);
  return all;
}

// The values of every input (outputs.hpp) at the state asked for.
struct EvalInputs {
  std::map<Input, Eigen::VectorXd> values;
  Eigen::VectorXd params;
  std::vector<Eigen::VectorXd> of(const OutputInfo& o) const {
    std::vector<Eigen::VectorXd> in;
    for (Input i : o.inputs) in.push_back(values.at(i));
    return in;
  }
};

// GiNaC's value of each output the scene emits (composed ones by Eigen's solves).
void evaluate_symbolic(const ModelRecipe& scene, const EvalInputs& in, bool verbose,
                       nlohmann::ordered_json& out) {
  const auto t0 = clock::now();
  double derive_ms = -1;  // the first call's: it derives
  for (Output o : scene.facts().outputs) {
    const OutputInfo& info = spacearm::info(o);
    double ms = 0;
    out[info.name] =
        results_json(scene.name(), info, scene.evaluate_symbolic(o, in.of(info), in.params, &ms));
    if (derive_ms < 0 && verbose) std::fprintf(stderr, "spacearm: derive %.1f ms\n", ms);
    if (derive_ms < 0) derive_ms = ms;
  }
  if (verbose)
    std::fprintf(stderr, "spacearm: evaluate (GiNaC) %.1f ms\n", ms_since(t0) - derive_ms);
}

// The compiled model's value of each output the scene emits.
void evaluate_compiled(const ModelRecipe& scene, const EvalArgs& a, const EvalInputs& in,
                       nlohmann::ordered_json& out) {
  CompileOptions options;
  options.cache_dir = a.cache_dir;
  options.engine = parse_engine(a.engine);
  options.progress = [verbose = a.verbose](const std::string& m) {
    if (verbose || worth_saying(m) || m.rfind("deriving", 0) == 0)
      std::fprintf(stderr, "spacearm: %s%s\n", m.c_str(), verbose ? "" : " ...");
  };
  StageReport rep;
  const auto model = CompiledModel::load(scene, options, &rep);
  if (a.verbose) std::fprintf(stderr, "spacearm: %s\n", stage_line(rep).c_str());
  const auto t0 = clock::now();
  with_span_note([&] { return model.span_note(in.params); },
                 [&] {
                   for (const auto& o : output_registry())
                     if (model.has(o.id))
                       out[o.name] =
                           results_json(scene.name(), o, model.evaluate(o.id, in.of(o), in.params));
                 });
  if (a.verbose)
    std::fprintf(stderr, "spacearm: run %.3f ms\nspacearm: %s\n", ms_since(t0),
                 model.engine_report().c_str());
}

// Each joint's gear ratio at the parameters used (1 without a gear).
Eigen::VectorXd gear_ratio_values(const ModelRecipe& recipe, const Eigen::VectorXd& params) {
  const std::vector<Quantity> p = recipe.gear_ratios();
  Eigen::VectorXd ratios(static_cast<Eigen::Index>(p.size()));
  for (size_t j = 0; j < p.size(); ++j)
    ratios[static_cast<Eigen::Index>(j)] = p[j].is_parameter() ? params[p[j].index] : p[j].value;
  return ratios;
}

// Generalized forces of joint torques tau (eq. 14), the gear ratios at the parameters used.
Eigen::VectorXd generalized_forces(const ModelRecipe& recipe, const Eigen::VectorXd& params,
                                   const Eigen::VectorXd& tau) {
  const ModelFacts& facts = recipe.facts();
  Eigen::VectorXd Q(facts.dims.nv);
  joint_torques_as_forces(tau, gear_ratio_values(recipe, params), actuated_coordinates(facts), Q);
  return Q;
}

// --state-from and --state-to: a spatial free base's state in another tool's convention, the
// joints as link angles (a motor slot over its ratio at the parameters used).
struct StateConversion {
  StateConvention from = StateConvention::spacearm;
  std::optional<StateConvention> to;
  Eigen::Vector3d base_com = Eigen::Vector3d::Zero();
  Eigen::VectorXd ratios;
};

StateConversion state_conversion(const ModelRecipe& scene, const EvalArgs& a,
                                 const Eigen::VectorXd& params) {
  StateConversion c;
  c.from = state_convention(a.state_from, "--state-from");
  if (!a.state_to.empty()) c.to = state_convention(a.state_to, "--state-to");
  const ModelFacts& facts = scene.facts();
  if ((c.from != StateConvention::spacearm || c.to) && !(facts.dims.spatial && facts.free_floating))
    throw std::invalid_argument(std::string(c.to ? "--state-to" : "--state-from") +
                                ": converts a spatial scene's free base; '" + facts.name +
                                "' has none");
  const std::vector<double> p(params.data(), params.data() + params.size());
  const auto com = scene.base_com(p);
  c.base_com = Eigen::Vector3d(com[0], com[1], com[2]);
  c.ratios = gear_ratio_values(scene, params);
  for (int j = 0; j < c.ratios.size(); ++j)  // a slot that holds the link angle converts as is
    if (!(j < static_cast<int>(facts.motor_angle_slots.size()) && facts.motor_angle_slots[j]))
      c.ratios[j] = 1;
  return c;
}

nlohmann::ordered_json state_json(const std::string& convention, const BaseState& s) {
  return {{"convention", convention},
          {"q", std::vector<double>(s.q.data(), s.q.data() + s.q.size())},
          {"v", std::vector<double>(s.v.data(), s.v.data() + s.v.size())}};
}

}  // namespace

int run_eval(const EvalArgs& a) {
  const ModelRecipe scene = cli::load_scene(a.scene_path);
  const ModelFacts& facts = scene.facts();
  const int nq = facts.dims.nq, nv = facts.dims.nv, N = facts.dims.num_links;
  if (a.symbolic && !scene.has_closed_forms())
    throw std::invalid_argument("--symbolic: model '" + facts.name +
                                "' is a spatial arm, which has no symbolic derivation");
  auto vector = [](const std::string& text, const char* option, int size) {
    return text.empty() ? Eigen::VectorXd::Zero(size) : cli::parse_vector(text, option, size);
  };
  EvalInputs in;
  if (a.q_text.empty()) {  // the home state, said so (MuJoCo's qpos0)
    in.values[Input::q] = ConfigurationSpace{nq, nv, facts.quaternion_offset}.neutral();
    std::fprintf(stderr,
                 "spacearm: --q not given: the home state (base at the origin%s, joints at 0)\n",
                 facts.quaternion_offset >= 0 ? ", identity quaternion" : "");
  } else {
    in.values[Input::q] = cli::parse_vector(a.q_text, "--q", nq);
  }
  in.values[Input::qd] = vector(a.qd_text, "--qd", nv);
  in.params = cli::parse_parameters(a.param_assignments, facts);
  const StateConversion conversion = state_conversion(scene, a, in.params);
  const BaseState given{in.values[Input::q], in.values[Input::qd]};
  if (conversion.from != StateConvention::spacearm) {
    try {
      const BaseState s = from_convention(conversion.from, given.q, given.v, conversion.base_com,
                                          conversion.ratios);
      in.values[Input::q] = s.q, in.values[Input::qd] = s.v;
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("--q (--state-from " + a.state_from + "): " + e.what());
    }
  }
  // The angles' bound on spacearm's coordinates, after a conversion (p times a link angle).
  const int first_angle = ConfigurationSpace::first_angle(facts.free_floating, facts.dims.spatial);
  if (const std::string e = ConfigurationSpace::angle_error(in.values[Input::q], first_angle, "--q",
                                                            facts.coordinate_names);
      !e.empty())
    throw std::invalid_argument(e);
  in.values[Input::qdd] = vector(a.qdd_text, "--qdd", nv);
  in.values[Input::generalized_forces] = vector(a.forces_text, "--forces", nv);
  in.values[Input::joint_accelerations] = vector(a.qdd_joints_text, "--qdd-joints", N);
  const Eigen::VectorXd tau =
      a.tau_text.empty() ? Eigen::VectorXd() : cli::parse_vector(a.tau_text, "--tau", N);
  if (tau.size()) in.values[Input::generalized_forces] = generalized_forces(scene, in.params, tau);
  // An input that no output of the scene takes would do nothing: an error, not ignored.
  std::set<Input> used;
  for (Output o : facts.outputs) used.insert(info(o).inputs.begin(), info(o).inputs.end());
  for (const auto& [input, text, option] :
       {std::make_tuple(Input::qdd, a.qdd_text, "--qdd"),
        std::make_tuple(Input::generalized_forces, a.forces_text, "--forces"),
        std::make_tuple(Input::generalized_forces, a.tau_text, "--tau"),
        std::make_tuple(Input::joint_accelerations, a.qdd_joints_text, "--qdd-joints")})
    if (!text.empty() && !used.count(input))
      throw std::invalid_argument(std::string(option) + ": the scene emits no output that takes " +
                                  info(input).name + " (field 'outputs')");
  // The state, inputs and parameters used, then every output by its registry name.
  nlohmann::ordered_json out;
  out["coordinates"] = facts.coordinate_names;
  if (!facts.joint_parents.empty()) {  // a tree: its joints depth-first, each one's parent
    out["joints"] = facts.joint_names;
    out["joint_parents"] = facts.joint_parents;
  }
  if (facts.dims.num_end_effectors > 1) out["end_effectors"] = facts.end_effector_names;
  for (const auto& [input, v] : in.values)
    if (input == Input::q || used.count(input))
      out[info(input).name] = std::vector<double>(v.data(), v.data() + v.size());
  if (tau.size()) out["tau"] = std::vector<double>(tau.data(), tau.data() + tau.size());
  if (conversion.from != StateConvention::spacearm)
    out["given_state"] = state_json(a.state_from, given);
  if (conversion.to)
    out["state_" + a.state_to] = state_json(
        a.state_to, to_convention(*conversion.to, in.values[Input::q], in.values[Input::qd],
                                  conversion.base_com, conversion.ratios));
  out["parameters"] = nlohmann::ordered_json::object();
  for (size_t i = 0; i < facts.parameter_names.size(); ++i)
    out["parameters"][facts.parameter_names[i]] = in.params[i];
  if (a.symbolic)
    evaluate_symbolic(scene, in, a.verbose, out);
  else
    evaluate_compiled(scene, a, in, out);
  // A URDF's names need not be UTF-8: such bytes print as U+FFFD, never an exception that loses
  // the output.
  const auto replace = nlohmann::ordered_json::error_handler_t::replace;
  std::cout << (a.compact_json ? out.dump(-1, ' ', false, replace)
                               : out.dump(2, ' ', false, replace))
            << "\n";
  return 0;
}

}  // namespace spacearm
