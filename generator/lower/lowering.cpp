#include "lowering.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <stdexcept>

#include <Eigen/Dense>

#include "composition.hpp"
#include "closed_forms.hpp"

namespace spacearm {

using GiNaC::ex;

bool DerivedModel::has_closed_form(Output o) const {
  return closed_forms && closed_forms->outputs.count(o) != 0;
}

namespace {

// A fixed pseudo-random state and the nominal parameters, where lowering checks itself.
struct CheckPoint {
  std::vector<double> q, qd, params;
  explicit CheckPoint(const DerivedModel& model) : params(model.facts.nominal_parameters) {
    for (int i = 0; i < model.facts.dims.nq; ++i) q.push_back(0.3 + 0.7 * std::sin(1.3 * i + 0.4));
    for (int i = 0; i < model.facts.dims.nv; ++i) qd.push_back(0.5 - 0.9 * std::cos(0.7 * i + 1.1));
    // A quaternion of unit length, as every state of such a model has.
    if (const int k = model.facts.quaternion_offset; k >= 0) {
      const double n =
          std::sqrt(q[k] * q[k] + q[k + 1] * q[k + 1] + q[k + 2] * q[k + 2] + q[k + 3] * q[k + 3]);
      for (int i = k; i < k + 4; ++i) q[i] /= n;
    }
  }
  // Entry `index` of an input array; the composed outputs' other inputs (qdd, Q, qdd_joints)
  // get fixed values of their own.
  double input(const std::string& array, int index) const {
    if (array == "q") return q.at(index);
    if (array == "qd") return qd.at(index);
    if (array == "params") return params.at(index);
    return 0.2 + 0.3 * std::cos(1.7 * index + array.size());
  }
};

// "" or where the nominal values span too many decades for double, by field (value_span.hpp):
// what a failing self-check names.
std::string nominal_span(const DerivedModel& model) {
  return value_span(model.facts.span_fields, nullptr, model.facts.parameter_names);
}

// The generator checks itself before it emits: the optimized straight-line program must
// reproduce, at the check point, the values computed from the derivation alone (want: per
// result, its entries row by row), else it names the entry that fails.
void self_check(const DerivedModel& model, const FunctionSpec& f,
                const std::vector<std::vector<double>>& want) {
  const CheckPoint at(model);
  for (size_t k = 0; k < f.results.size(); ++k) {
    const auto got = f.program.evaluate(
        f.entries[k], [&](const std::string& a, int i) { return at.input(a, i); });
    if (got.size() != want[k].size())
      throw std::logic_error("self-check: " + f.name + " has a wrong entry count");
    double scale = 1e-300;
    for (double w : want[k]) {
      // Not a generator bug but a scene whose numbers make the model degenerate in double.
      if (!std::isfinite(w)) {
        const std::string span = nominal_span(model);
        throw std::runtime_error(
            "scene '" + model.facts.name + "': " + f.name +
            " is not finite at the generator's check point (nominal parameters): the masses, "
            "inertias or lengths make the model numerically degenerate" +
            (span.empty() ? "" : " (its values span " + span + ")"));
      }
      scale = std::max(scale, std::abs(w));
    }
    for (size_t i = 0; i < want[k].size(); ++i) {
      if (std::abs(got[i] - want[k][i]) <= 1e-9 * scale) continue;
      char values[120];
      std::snprintf(values, sizeof values, "%.17g emitted vs %.17g derived", got[i], want[k][i]);
      const std::string where =
          f.name + ", " + f.results[k].name + " entry " + std::to_string(i) + ": " + values;
      // Numbers too far apart for double are the scene's, named by field; else a generator bug.
      if (const std::string span = nominal_span(model); !span.empty())
        throw std::runtime_error(
            "scene '" + model.facts.name +
            "': double precision cannot hold this model at its nominal values (" + where +
            "): its values span " + span +
            "; choose units or nominal values that bring them closer");
      throw std::logic_error("generator self-check failed in " + where);
    }
  }
}

// What lowering minimizes: arithmetic operations plus calls of sin/cos, tanh and exp.
int cost(const FunctionSpec& f) {
  const OpCounts ops = f.program.count(f.roots());
  return ops.total_arithmetic() + ops.trig + ops.functions;
}

// Lowers f in each velocity basis (both when it uses velocities): `build` makes the entries
// in the builder's program; CSE, the self-check against `want`, and the cheaper one is kept.
FunctionSpec cheapest_lowering(
    const DerivedModel& model, const FunctionSpec& f,
    const std::function<std::vector<std::vector<SRef>>(ExpressionBuilder&)>& build,
    const std::vector<std::vector<double>>& want) {
  const bool uses_velocity = std::any_of(f.inputs.begin(), f.inputs.end(), [](const ArraySpec& a) {
    return a.name == info(Input::qd).name;
  });
  FunctionSpec best;
  int best_cost = -1;
  for (int basis = 0; basis < (uses_velocity ? 2 : 1); ++basis) {
    const std::unique_ptr<ExpressionBuilder> fb = model.closed_form_builder(basis == 1);
    FunctionSpec candidate = f;
    candidate.entries = build(*fb);
    fb->program().extract_common_pairs(candidate.roots());
    candidate.program = std::move(fb->program());
    self_check(model, candidate, want);
    const int candidate_cost = cost(candidate);
    if (best_cost >= 0 && candidate_cost >= best_cost) continue;
    candidate.variant = uses_velocity ? (basis == 1 ? "omega" : "qd") : "";
    best = std::move(candidate);
    best_cost = candidate_cost;
  }
  return best;
}

// The arrays of an output as the registry gives them; a 4-lane version where the registry or
// the scene (ModelFacts::lanes) asks for one.
void describe(FunctionSpec& f, const OutputInfo& o, const ModelFacts& facts) {
  f.name = o.name;
  f.doc = o.doc;
  f.equation = o.equation;
  f.lanes = has_lanes_version(o.id) || std::count(facts.lanes.begin(), facts.lanes.end(), o.id);
  for (Input i : o.inputs) f.inputs.push_back({info(i).name, info(i).size, Size::one});
  for (const auto& r : o.results) f.results.push_back({r.name, r.rows, r.cols, r.symmetric});
}

// A function whose results are closed-form expressions (row by row per result): lowered
// with both velocity bases when it uses velocities, keeping the cheaper program.
FunctionSpec lower_closed_form(const DerivedModel& model, FunctionSpec f,
                               const std::vector<std::vector<ex>>& results, bool plain) {
  if (plain) {
    const std::unique_ptr<ExpressionBuilder> pb = plain_builder(
        {model.closed_forms->q, model.closed_forms->qd, model.closed_forms->parameters});
    for (const auto& r : results) {
      f.entries.emplace_back();
      for (const ex& e : r) f.entries.back().push_back(pb->build(e.expand()));
    }
    f.program = std::move(pb->program());
    f.plain = true;
    f.formulation = "closed form";
    return f;
  }
  const CheckPoint at(model);
  std::vector<std::vector<double>> want;
  for (const auto& r : results) {
    auto& w = want.emplace_back();
    for (const ex& e : r) w.push_back(evaluate(*model.closed_forms, e, at.q, at.qd, at.params));
  }
  auto build = [&](ExpressionBuilder& fb) {
    std::vector<std::vector<SRef>> entries;
    for (size_t k = 0; k < results.size(); ++k) {
      auto& out = entries.emplace_back();
      const int cols = model.facts.dims(f.results[k].cols);
      for (size_t e = 0; e < results[k].size(); ++e) {
        // A symmetric result's lower triangle repeats its upper one (built once).
        const int i = static_cast<int>(e) / cols, j = static_cast<int>(e) % cols;
        out.push_back(f.results[k].symmetric && j < i ? out[j * cols + i]
                                                      : fb.build(results[k][e]));
      }
    }
    return entries;
  };
  FunctionSpec lowered = cheapest_lowering(model, f, build, want);
  lowered.formulation = "closed form";
  return lowered;
}

// The composed output's values at the check point, from the derivation alone.
std::vector<Eigen::MatrixXd> composed_reference(const DerivedModel& model, Output o,
                                                const CheckPoint& at) {
  std::vector<Eigen::VectorXd> inputs;
  for (Input i : info(o).inputs) {
    Eigen::VectorXd v(model.facts.dims(info(i).size));
    for (int k = 0; k < v.size(); ++k) v[k] = at.input(info(i).name, k);
    inputs.push_back(v);
  }
  const Eigen::VectorXd params =
      Eigen::Map<const Eigen::VectorXd>(at.params.data(), at.params.size());
  return model.reference(o, inputs, params);
}

// A composed output, checked against Eigen's solves of GiNaC's values.
FunctionSpec lower_composed(const DerivedModel& model, const FunctionSpec& f, Output o) {
  std::vector<std::vector<double>> want;
  for (const Eigen::MatrixXd& m : composed_reference(model, o, CheckPoint(model))) {
    const Eigen::MatrixXd rows = m.transpose();  // entries row by row
    want.emplace_back(rows.data(), rows.data() + rows.size());
  }
  FunctionSpec composed = cheapest_lowering(
      model, f, [&](ExpressionBuilder& fb) { return compose(model, fb, o); }, want);
  composed.formulation =
      model.has_closed_form(Output::mass_matrix) ? "closed form" : "recursive (CRBA, RNEA)";
  return composed;
}

// A function whose results come from the recursive algorithms (planar_chain.hpp), recorded
// in one program and checked against the same algorithms run in double.
FunctionSpec lower_recursive(const DerivedModel& model, FunctionSpec f,
                             const std::vector<Output>& parts) {
  const CheckPoint at(model);
  auto input = [&](const std::string& a, int i) { return at.input(a, i); };
  std::vector<std::vector<double>> want;
  std::string algorithms;
  for (Output o : parts) {
    const RecordedForm& form = model.recorded.at(o);
    for (auto& r : form.record(f.program)) f.entries.push_back(std::move(r));
    for (auto& w : form.evaluate(input)) want.push_back(std::move(w));
    algorithms += (algorithms.empty() ? "" : " + ") + std::string(form.algorithm);
  }
  f.program.extract_common_pairs(f.roots());
  self_check(model, f, want);
  f.formulation = "recursive (" + algorithms + ")";
  return f;
}

// Whether `parts` (outputs, or what a composed one is made of) were all derived in closed form.
bool has_closed_forms(const DerivedModel& model, const std::vector<Output>& parts) {
  return std::all_of(parts.begin(), parts.end(),
                     [&](Output o) { return model.has_closed_form(o); });
}

// One function of the outputs `parts` (one output, or M and b together): its closed form where
// it was derived, its recursive form where the scene tries it, the cheaper of the two.
FunctionSpec lower_function(const DerivedModel& model, const FunctionSpec& f,
                            const std::vector<Output>& parts, bool plain) {
  const bool recursive =
      !plain && model.tries_recursive &&
      std::all_of(parts.begin(), parts.end(), [&](Output o) { return model.recorded_form(o); });
  const OutputInfo& first = info(parts[0]);
  std::vector<FunctionSpec> candidates;
  if (!first.composed_of.empty()) {
    // Composed of M and b: from their closed forms, or from their recursive ones when only
    // those were derived (no candidate of its own where a recursive algorithm covers it).
    if (has_closed_forms(model, first.composed_of) || !recursive)
      candidates.push_back(lower_composed(model, f, parts[0]));
  } else if (has_closed_forms(model, parts)) {
    std::vector<std::vector<ex>> results;
    for (Output o : parts) results.push_back(entries_of(model.closed_forms->expression(o)));
    candidates.push_back(lower_closed_form(model, f, results, plain));
  }
  if (recursive) candidates.push_back(lower_recursive(model, f, parts));
  if (candidates.empty()) throw std::logic_error("lowering: no formulation derived for " + f.name);
  auto cheaper = [](const FunctionSpec& a, const FunctionSpec& b) { return cost(a) < cost(b); };
  return std::move(*std::min_element(candidates.begin(), candidates.end(), cheaper));
}

}  // namespace

LoweredModel lower(const DerivedModel& model, const LowerOptions& options) {
  LoweredModel lowered;
  lowered.facts = model.facts;
  std::vector<Output>& outputs = lowered.facts.outputs;  // in the registry's order
  if (options.plain) {  // the baseline: closed forms only, under its own name
    lowered.facts.name += "_plain";
    outputs.erase(std::remove_if(outputs.begin(), outputs.end(),
                                 [](Output o) { return !info(o).composed_of.empty(); }),
                  outputs.end());
  }
  const bool has_mass_matrix = std::count(outputs.begin(), outputs.end(), Output::mass_matrix) != 0;
  for (Output o : outputs) {
    FunctionSpec f;
    describe(f, info(o), lowered.facts);
    lowered.functions.push_back(lower_function(model, f, {o}, options.plain));
    // M and b together, sharing the sin/cos and common terms (what forward dynamics needs).
    if (o == Output::bias_forces && has_mass_matrix) {
      FunctionSpec mb;
      mb.name = kMassMatrixAndBias;
      mb.doc = "M and b together, sharing the sin/cos and common terms.";
      mb.inputs = {{"q", Size::nq, Size::one}, {"qd", Size::nv, Size::one}};
      mb.results = {{"M", Size::nv, Size::nv, true}, {"b", Size::nv, Size::one, false}};
      lowered.functions.push_back(
          lower_function(model, mb, {Output::mass_matrix, Output::bias_forces}, options.plain));
    }
  }
  // Always emitted: the runtime maps joint torques to generalized forces tau / p (eq. 14).
  FunctionSpec ratios;
  ratios.name = "gear_ratios";
  ratios.doc = "Gear ratio p_i of each joint (1 for the reference model): Q_g = tau / p.";
  ratios.equation = "14";
  ratios.results = {{"p", Size::num_links, Size::one, false}};
  if (model.closed_forms) {
    lowered.functions.push_back(
        lower_closed_form(model, ratios, {model.closed_forms->ratios}, options.plain));
  } else {
    if (!model.gear_ratios.record)
      throw std::logic_error("lowering: model " + model.facts.name + " states no gear ratios");
    FunctionSpec f = ratios;
    f.entries = model.gear_ratios.record(f.program);
    const CheckPoint at(model);
    self_check(model, f, model.gear_ratios.evaluate([&at](const std::string& a, int i) {
      return at.input(a, i);
    }));
    f.formulation = "constant";
    lowered.functions.push_back(std::move(f));
  }
  lowered.functions.back().model_constant = true;
  return lowered;
}

}  // namespace spacearm
