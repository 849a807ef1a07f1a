// The recursive forms (generator/derive/planar/planar_chain.hpp) against the closed forms,
// evaluated by GiNaC and Eigen (numeric_outputs.hpp), on every model kind for N = 1..6, and against
// the numeric Lagrangian oracle (no generator code) on long chains up to N = 30. Both the
// algorithms run in double and their recorded, CSE'd programs are checked.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <map>

#include "cpp_emitter.hpp"
#include "numeric_outputs.hpp"
#include "planar_model.hpp"
#include "planar_chain.hpp"
#include "support.hpp"
#include "symbolic_model.hpp"

namespace spacearm {
namespace {

// The outputs with a recursive form that scene s has (momentum: a free base only).
std::vector<Output> recursive_outputs(const Scene& s) {
  std::vector<Output> outputs;
  for (const OutputInfo& o : output_registry())
    if (has_recursive_form(o.id) && (o.id != Output::momentum || s.free_floating()))
      outputs.push_back(o.id);
  return outputs;
}

// A random state: q, qd, qdd, Q and the nominal parameters, by input name.
struct State {
  std::map<std::string, Eigen::VectorXd> arrays;
  State(const Scene& s, unsigned seed) {
    std::mt19937 rng(seed);
    const int n = s.num_coordinates();
    for (const char* name : {"q", "qd", "qdd", "Q"})
      arrays[name] = test::random_vector(rng, n, 1.5);
    Eigen::VectorXd p(s.parameters.size());
    for (size_t i = 0; i < s.parameters.size(); ++i) p[i] = s.parameters[i].nominal.value;
    arrays["params"] = p;
  }
  double operator()(const std::string& array, int i) const { return arrays.at(array)[i]; }
};

Eigen::MatrixXd rows_of(const std::vector<double>& v, Eigen::Index rows) {
  return Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      v.data(), rows, static_cast<Eigen::Index>(v.size()) / rows);
}

// The recursive output o, run in double and as its recorded program after CSE.
std::pair<std::vector<std::vector<double>>, std::vector<std::vector<double>>> recursive(
    const Scene& s, Output o, const State& x) {
  auto input = [&](const std::string& a, int i) { return x(a, i); };
  Program p;
  const auto refs = record_recursive(s, o, p);
  std::vector<SRef> roots;
  for (const auto& r : refs) roots.insert(roots.end(), r.begin(), r.end());
  p.extract_common_pairs(roots);
  std::vector<std::vector<double>> recorded;
  for (const auto& r : refs) recorded.push_back(p.evaluate(r, input));
  return {evaluate_recursive(s, o, input), recorded};
}

// ABA eliminates from the tip inward: every coordinate after its descendants (the motors of
// flexible joints, the joints from N down to 1), then the base in (x0, y0, q0). Its pivots are
// those of LDL^T of M in that order.
Eigen::VectorXd tip_first_pivots(const Scene& s, const Eigen::MatrixXd& M) {
  const int n = s.num_coordinates(), nb = s.num_base();
  std::vector<int> order;
  for (int i = n - 1; i >= nb; --i) order.push_back(i);
  for (int i = 0; i < nb; ++i) order.push_back(i);
  Eigen::MatrixXd P(n, n);
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) P(a, b) = M(order[a], order[b]);
  // Gaussian elimination without pivoting (Eigen's LDLT reorders by size).
  Eigen::VectorXd D(n);
  Eigen::MatrixXd A = P;
  for (int k = 0; k < n; ++k) {
    D[k] = A(k, k);
    for (int i = k + 1; i < n; ++i)
      for (int j = k + 1; j < n; ++j) A(i, j) -= A(i, k) * A(k, j) / D[k];
  }
  Eigen::VectorXd pivots(n);
  for (int a = 0; a < n; ++a) pivots[order[a]] = D[a];
  return pivots;
}

// Every recursive output against the closed form at one random state.
void expect_closed_form_agrees(Scene s, unsigned seed) {
  const std::vector<Output> outputs = recursive_outputs(s);
  EXPECT_GE(outputs.size(), 5u);
  s.outputs = {outputs.begin(), outputs.end()};
  const SymbolicModel model = derive(s);
  const State x(s, seed);
  for (Output o : outputs) {
    SCOPED_TRACE(s.name + ": " + to_string(o));
    std::vector<Eigen::VectorXd> in;
    for (Input i : info(o).inputs) in.push_back(x.arrays.at(info(i).name));
    std::vector<Eigen::MatrixXd> closed = evaluate_output(model, o, in, x.arrays.at("params"));
    if (o == Output::forward_dynamics) {  // the closed form's pivots are head-first
      const Eigen::MatrixXd M =
          evaluate_output(model, Output::mass_matrix, {in[0]}, x.arrays.at("params"))[0];
      closed[1] = tip_first_pivots(s, M);
      closed[2] = closed[1].cwiseQuotient(M.diagonal());
    }
    const auto [run, recorded] = recursive(s, o, x);
    ASSERT_EQ(run.size(), closed.size());
    for (size_t k = 0; k < closed.size(); ++k) {
      if (closed[k].isZero(0)) {  // the bias of one link on a fixed base
        EXPECT_EQ(Eigen::Map<const Eigen::VectorXd>(run[k].data(), run[k].size()).norm(), 0);
        continue;
      }
      EXPECT_MATRIX_NEAR(rows_of(run[k], closed[k].rows()), closed[k], 1e-11);
      EXPECT_MATRIX_NEAR(rows_of(recorded[k], closed[k].rows()), closed[k], 1e-11);
    }
  }
}

TEST(RecursiveDynamics, AgreesWithClosedFormOnRandomChains) {
  for (int links = 1; links <= 6; ++links)
    for (bool free : {true, false})
      for (bool geared : {false, true}) {
        test::ChainSpec spec;
        spec.links = links;
        spec.free_floating = free;
        spec.geared = geared;
        spec.outputs = "[mass_matrix]";
        spec.seed = 17 * links + 3 * free + geared;
        expect_closed_form_agrees(parse_scene(test::random_scene_yaml(spec), "random.yaml"),
                                  spec.seed);
      }
}

TEST(RecursiveDynamics, AgreesWithClosedFormOnTestAndPaperModels) {
  for (const char* path :
       {"/tests/scenes/free_n4_mixed.yaml", "/tests/scenes/fixed_n4_geared.yaml",
        "/tests/scenes/fixed_n5_geared_params.yaml", "/tests/scenes/free_n3_base_params.yaml",
        "/tests/scenes/fixed_n1.yaml", "/models/paper_flexible.yaml",
        "/models/paper_geared_armature.yaml", "/models/paper_geared.yaml"})
    expect_closed_form_agrees(load_scene(std::string(SPACEARM_SOURCE_DIR) + path), 5);
}

// Long chains, where no closed form is affordable: M, b, forward dynamics, T and the momentum
// against the numeric Lagrangian (M by polarization of T, b by central differences of T:
// agreement to 1e-6; T and the momentum from its bodies' velocities).
TEST(RecursiveDynamics, AgreesWithNumericOracleOnLongChains) {
  for (int links : {12, 20, 30})
    for (bool geared : {false, true}) {
      test::ChainSpec spec;
      spec.links = links;
      spec.geared = geared;
      spec.outputs = "[mass_matrix]";
      spec.seed = links + geared;
      const Scene s = parse_scene(test::random_scene_yaml(spec), "long.yaml");
      SCOPED_TRACE(s.name);
      const NumericLagrangian oracle(test::chain_parameters(s));
      const State x(s, spec.seed);
      const Eigen::VectorXd &q = x.arrays.at("q"), &qd = x.arrays.at("qd"), &Q = x.arrays.at("Q");
      const Eigen::MatrixXd M = oracle.mass_matrix(q);
      const Eigen::VectorXd b = oracle.bias_forces(q, qd);
      const std::map<Output, Eigen::MatrixXd> oracle_values = {
          {Output::mass_matrix, M},
          {Output::bias_forces, b},
          {Output::forward_dynamics, M.ldlt().solve(Q - b)},
          {Output::kinetic_energy, Eigen::MatrixXd::Constant(1, 1, oracle.kinetic_energy(q, qd))},
          {Output::momentum, oracle.momentum(q, qd)}};
      const SymbolicModel model = derive(s);  // no closed form at these N
      for (const auto& [o, want] : oracle_values) {
        // eval --symbolic's values (numeric_outputs.hpp), shaped as the registry says.
        if (o == Output::kinetic_energy || o == Output::momentum) {
          const Eigen::MatrixXd value =
              evaluate_output(model, o, {q, qd}, x.arrays.at("params"))[0];
          EXPECT_MATRIX_NEAR(value, want, 1e-6);
        }
        const auto [run, recorded] = recursive(s, o, x);
        EXPECT_MATRIX_NEAR(rows_of(run[0], want.rows()), want, 1e-6);
        EXPECT_MATRIX_NEAR(rows_of(recorded[0], want.rows()), want, 1e-6);
      }
    }
}

// The derivatives past the closed form's reach, by central differences: Mdot along qd and P = d(M
// qd)/dq from the oracle's M (exact by polarization), so C of eq. 7 = Mdot - P^T / 2 and the
// Christoffel form (Mdot + P - P^T) / 2; C qd and Cc qd against the oracle's bias; the state
// Jacobian against differences of forward dynamics run in double (checked above against the
// oracle). Cost: about 3 s, most of it recording and CSE of N = 30's state Jacobian.
TEST(RecursiveDynamics, DerivativesAgreeWithDifferencesOnLongChains) {
  for (int links : {12, 30}) {
    test::ChainSpec spec;
    spec.links = links;
    spec.geared = true;
    spec.outputs = "[mass_matrix]";
    spec.seed = 3 * links;
    const Scene s = parse_scene(test::random_scene_yaml(spec), "long.yaml");
    SCOPED_TRACE(s.name);
    const NumericLagrangian oracle(test::chain_parameters(s));
    State x(s, spec.seed);
    const Eigen::VectorXd q = x.arrays.at("q"), qd = x.arrays.at("qd");
    const int n = s.num_coordinates();
    const double h = 1e-5;
    const Eigen::MatrixXd Mdot =
        (oracle.mass_matrix(q + h * qd) - oracle.mass_matrix(q - h * qd)) / (2 * h);
    Eigen::MatrixXd P(n, n);
    for (int k = 0; k < n; ++k) {
      const Eigen::VectorXd e = h * Eigen::VectorXd::Unit(n, k);
      P.col(k) = (oracle.mass_matrix(q + e) - oracle.mass_matrix(q - e)) * qd / (2 * h);
    }
    const Eigen::VectorXd b = oracle.bias_forces(q, qd);
    const std::map<Output, Eigen::MatrixXd> want = {
        {Output::mass_matrix_derivative, Mdot},
        {Output::coriolis_matrix, Mdot - P.transpose() / 2},
        {Output::christoffel_coriolis_matrix, (Mdot + P - P.transpose()) / 2}};
    for (const auto& [o, value] : want) {
      SCOPED_TRACE(to_string(o));
      const auto [run, recorded] = recursive(s, o, x);
      EXPECT_MATRIX_NEAR(rows_of(run[0], n), value, 1e-7);
      EXPECT_MATRIX_NEAR(rows_of(recorded[0], n), value, 1e-7);
      if (o != Output::mass_matrix_derivative) EXPECT_MATRIX_NEAR(rows_of(run[0], n) * qd, b, 1e-6);
    }
    // Forward dynamics' state Jacobian, column by column; its qdd is forward dynamics'.
    auto qdd = [&](const State& at) {
      return rows_of(recursive(s, Output::forward_dynamics, at).first[0], n);
    };
    Eigen::MatrixXd dq(n, n), dqd(n, n);
    for (int k = 0; k < n; ++k)
      for (const char* wrt : {"q", "qd"}) {
        State plus = x, minus = x;
        plus.arrays[wrt][k] += h;
        minus.arrays[wrt][k] -= h;
        (wrt[1] ? dqd : dq).col(k) = (qdd(plus) - qdd(minus)) / (2 * h);
      }
    // dqdd/dtau: joint j's torque as tau / p on its motor coordinate (parameters at nominal).
    const int N = s.num_links();
    Eigen::MatrixXd dtau(n, N);
    for (int j = 0; j < N; ++j) {
      State plus = x, minus = x;
      const double per_torque = s.has_gear(j) ? 1 / s.gears[j]->ratio.value : 1;
      plus.arrays["Q"][s.motor_coordinate(j)] += per_torque;
      minus.arrays["Q"][s.motor_coordinate(j)] -= per_torque;
      dtau.col(j) = (qdd(plus) - qdd(minus)) / 2;  // qdd is affine in Q
    }
    const auto [run, recorded] = recursive(s, Output::forward_dynamics_derivatives, x);
    for (const auto& r : {run, recorded}) {
      EXPECT_MATRIX_NEAR(rows_of(r[0], n), dq, 1e-6);
      EXPECT_MATRIX_NEAR(rows_of(r[1], n), dqd, 1e-6);
      // A free base's x0 and y0 rates move no acceleration (a Galilean boost): exact zeros.
      if (s.num_base() > 0) EXPECT_EQ(rows_of(r[1], n).leftCols(2).cwiseAbs().maxCoeff(), 0);
      EXPECT_MATRIX_NEAR(rows_of(r[2], n), qdd(x), 1e-15);
      ASSERT_EQ(r[3].size(), size_t(n * N));
      EXPECT_MATRIX_NEAR(rows_of(r[3], n), dtau, 1e-9 * (1 + dtau.norm()));
    }
    // eval --symbolic's values where no closed form was derived.
    const SymbolicModel model = derive(s);
    const auto symbolic = evaluate_output(model, Output::forward_dynamics_derivatives,
                                          {q, qd, x.arrays.at("Q")}, x.arrays.at("params"));
    EXPECT_MATRIX_NEAR(symbolic[0], rows_of(run[0], n), 1e-15);
    EXPECT_MATRIX_NEAR(symbolic[1], rows_of(run[1], n), 1e-15);
    EXPECT_MATRIX_NEAR(symbolic[3], dtau, 1e-9 * (1 + dtau.norm()));
  }
}

// Which formulation lowering keeps, per function, under each setting of the scene.
std::map<std::string, std::string> formulations(const std::string& yaml) {
  std::map<std::string, std::string> by_function;
  for (const FunctionSpec& f : lower(derive(parse_scene(yaml, "t.yaml"))).functions)
    by_function[f.name] = f.formulation;
  return by_function;
}

TEST(RecursiveDynamics, FormulationIsChosenPerFunctionAndCanBeForced) {
  test::ChainSpec spec;
  spec.geared = true;
  spec.outputs =
      "[mass_matrix, bias_forces, inverse_dynamics, forward_dynamics, end_effector_pose]";
  const std::string paper_size = test::random_scene_yaml(spec);
  for (const auto& [name, formulation] : formulations(paper_size + "formulation: closed\n")) {
    if (name == "gear_ratios") continue;  // a constant, derived by neither
    EXPECT_EQ(formulation, "closed form") << name;
  }
  auto forced = formulations(paper_size + "formulation: recursive\n");
  EXPECT_EQ(forced["mass_matrix"], "recursive (CRBA)");
  EXPECT_EQ(forced["bias_forces"], "recursive (RNEA)");
  EXPECT_EQ(forced["mass_matrix_and_bias"], "recursive (CRBA + RNEA)");
  EXPECT_EQ(forced["inverse_dynamics"], "recursive (RNEA)");
  EXPECT_EQ(forced["forward_dynamics"], "recursive (ABA)");
  EXPECT_EQ(forced["end_effector_pose"], "closed form");  // no recursive form
  // Past the closed form's reach, auto takes the recursive forms without deriving the others.
  spec.links = kClosedFormLinks + 4;
  spec.outputs = "[mass_matrix, bias_forces, forward_dynamics, generalized_jacobian]";
  auto long_chain = formulations(test::random_scene_yaml(spec));
  EXPECT_EQ(long_chain["mass_matrix_and_bias"], "recursive (CRBA + RNEA)");
  EXPECT_EQ(long_chain["forward_dynamics"], "recursive (ABA)");
  EXPECT_EQ(long_chain["generalized_jacobian"], "recursive (CRBA, RNEA)");
  // The derivatives too, by forward-mode differentiation of the algorithms.
  spec.outputs =
      "[coriolis_matrix, mass_matrix_derivative, christoffel_coriolis_matrix, "
      "forward_dynamics_derivatives]";
  long_chain = formulations(test::random_scene_yaml(spec));
  EXPECT_EQ(long_chain["coriolis_matrix"], "recursive (CRBA and momenta, forward-mode)");
  EXPECT_EQ(long_chain["mass_matrix_derivative"], "recursive (CRBA, forward-mode)");
  EXPECT_EQ(long_chain["christoffel_coriolis_matrix"],
            "recursive (CRBA and momenta, forward-mode)");
  EXPECT_EQ(long_chain["forward_dynamics_derivatives"], "recursive (RNEA and ABA, forward-mode)");
}

}  // namespace
}  // namespace spacearm
