// The derived symbolic model against invariants and against the independent numeric
// oracle (numeric_lagrangian.hpp), for N = 1..8, free-floating and fixed base, with and
// without gears. Evaluation here is GiNaC's own; test_generated_models checks the
// compiled code.
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "support.hpp"
#include "symbolic_model.hpp"

namespace spacearm {
namespace {

using test::ChainSpec;

enum class Gearing { none, numeric_per_joint, parameters };

struct Config {
  int links;
  bool free_floating;
  Gearing gearing;
};

std::string config_name(const testing::TestParamInfo<Config>& info) {
  const Config& c = info.param;
  return "N" + std::to_string(c.links) + (c.free_floating ? "_free" : "_fixed") +
         (c.gearing == Gearing::none         ? ""
          : c.gearing == Gearing::parameters ? "_geared_params"
                                             : "_geared");
}

ChainSpec spec_of(const Config& c) {
  ChainSpec spec;
  spec.links = c.links;
  spec.free_floating = c.free_floating;
  spec.geared = c.gearing != Gearing::none;
  spec.gear_parameters = c.gearing == Gearing::parameters;
  spec.seed = 100 * c.links + (c.free_floating ? 1 : 2) + 10 * static_cast<int>(c.gearing);
  spec.outputs = c.free_floating
                     ? "[mass_matrix, bias_forces, kinetic_energy, momentum, end_effector_pose]"
                     : "[mass_matrix, bias_forces, kinetic_energy, end_effector_pose]";
  return spec;
}

Eigen::MatrixXd evaluate_matrix(const SymbolicModel& m, const GiNaC::matrix& mat,
                                const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                const std::vector<double>& params = {}) {
  const auto values =
      evaluate(m, mat, {q.data(), q.data() + q.size()}, {qd.data(), qd.data() + qd.size()}, params);
  return Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      values.data(), mat.rows(), mat.cols());
}

class SymbolicModelTest : public testing::TestWithParam<Config> {};

TEST_P(SymbolicModelTest, MatchesIndependentNumericDerivation) {
  const ChainSpec spec = spec_of(GetParam());
  const Scene scene = parse_scene(test::random_scene_yaml(spec), "random.yaml");
  const SymbolicModel model = derive(scene);
  const NumericLagrangian oracle(test::chain_parameters(scene));
  std::mt19937 rng(spec.seed);
  const int n = model.n();
  for (int trial = 0; trial < 2; ++trial) {
    const Eigen::VectorXd q = test::random_vector(rng, n, 3.0),
                          qd = test::random_vector(rng, n, 2.0);
    const Eigen::MatrixXd M = evaluate_matrix(model, model.expression(Output::mass_matrix), q, qd);

    // M symmetric positive definite.
    EXPECT_EQ((M - M.transpose()).cwiseAbs().maxCoeff(), 0.0);
    Eigen::LLT<Eigen::MatrixXd> llt(M);
    ASSERT_EQ(llt.info(), Eigen::Success) << "M not positive definite at q = " << q.transpose();
    EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(M).eigenvalues().minCoeff(), 0.0);

    // Against the body-by-body oracle.
    EXPECT_MATRIX_NEAR(M, oracle.mass_matrix(q), 1e-10);
    const double T =
        evaluate(model, model.kinetic_energy, {q.data(), q.data() + n}, {qd.data(), qd.data() + n});
    EXPECT_NEAR(T, oracle.kinetic_energy(q, qd), 1e-12 * std::abs(T));
    EXPECT_NEAR(T, 0.5 * qd.dot(M * qd), 1e-12 * std::abs(T));
    // C qd (the bias) against the Euler-Lagrange terms by central differences (step 1e-6).
    // Their rounding error is ~eps/h ~1e-10 of the largest terms of T and M (base mass,
    // |qd| up to 2), while the bias can be 1e-3 of those: hence 1e-6 relative to max |b|
    // (measured up to 1.2e-7 for geared chains). A single link
    // on a fixed base has a constant M and so no bias at all: then the oracle must agree
    // to its own rounding, about eps |M| |qd| / h (polarization and differences of M).
    const Eigen::MatrixXd b = evaluate_matrix(model, model.expression(Output::bias_forces), q, qd);
    bool identically_zero = true;
    for (int i = 0; i < n; ++i)
      identically_zero &= model.expression(Output::bias_forces)(i, 0).is_zero();
    if (identically_zero) {
      EXPECT_TRUE(!spec.free_floating && spec.links == 1);
      EXPECT_LT(oracle.bias_forces(q, qd).cwiseAbs().maxCoeff(),
                1e-8 * M.norm() * std::max(qd.norm(), qd.squaredNorm()));
    } else {
      EXPECT_MATRIX_NEAR(b, oracle.bias_forces(q, qd), 1e-6);
    }
    EXPECT_MATRIX_NEAR(evaluate_matrix(model, model.expression(Output::end_effector_pose), q, qd),
                       oracle.end_effector_pose(q), 1e-12);
    if (spec.free_floating)
      EXPECT_MATRIX_NEAR(evaluate_matrix(model, model.expression(Output::momentum), q, qd),
                         oracle.momentum(q, qd), 1e-10);
  }
}

std::vector<Config> all_configs() {
  std::vector<Config> configs;
  for (int links = 1; links <= 8; ++links)
    for (bool free : {true, false})
      for (Gearing g : {Gearing::none, Gearing::numeric_per_joint, Gearing::parameters}) {
        if (links > 5 && g == Gearing::numeric_per_joint) continue;  // same algebra as parameters
        configs.push_back({links, free, g});
      }
  return configs;
}

INSTANTIATE_TEST_SUITE_P(Chains, SymbolicModelTest, testing::ValuesIn(all_configs()), config_name);

// Exact identities, checked symbolically (expanded difference is identically zero).
TEST(SymbolicIdentities, KineticEnergyIsHalfQdMQdAndCqdIsTheBias) {
  for (bool geared : {false, true}) {
    ChainSpec spec;
    spec.links = 3;
    spec.geared = geared;
    spec.gear_parameters = true;
    spec.outputs = "[mass_matrix, coriolis_matrix, bias_forces, kinetic_energy, momentum]";
    const SymbolicModel m = derive(parse_scene(test::random_scene_yaml(spec), "random.yaml"));
    const int n = m.n();
    GiNaC::matrix qd(n, 1);
    for (int i = 0; i < n; ++i) qd(i, 0) = m.qd[i];
    const GiNaC::ex quad = (qd.transpose().mul(m.expression(Output::mass_matrix)).mul(qd))(0, 0);
    ASSERT_FALSE(m.kinetic_energy.is_zero());
    EXPECT_TRUE((m.kinetic_energy - quad / 2).expand().is_zero());
    const GiNaC::matrix Cqd = m.expression(Output::coriolis_matrix).mul(qd);
    for (int i = 0; i < n; ++i) {
      EXPECT_TRUE((Cqd(i, 0) - m.expression(Output::bias_forces)(i, 0)).expand().is_zero())
          << "row " << i;
      // C(q, 0) = 0: every entry of C is linear in qd.
      GiNaC::exmap zero;
      for (int k = 0; k < n; ++k) zero[m.qd[k]] = 0;
      for (int j = 0; j < n; ++j)
        EXPECT_TRUE(m.expression(Output::coriolis_matrix)(i, j).subs(zero).expand().is_zero());
    }
    // (Momentum is checked against sum m v and sum r x m v + I w by the numeric oracle above,
    // and against finite differences of the compiled T in test_generated_models.)
  }
}

// A random three-link chain with geared joints (p and I_m as parameters), M and T.
std::string three_geared_links() {
  ChainSpec spec;
  spec.links = 3;
  spec.geared = spec.gear_parameters = true;
  spec.outputs = "[mass_matrix, kinetic_energy]";
  return test::random_scene_yaml(spec);
}

// The same scene with `rotor_coupling: coupling` on every gear.
std::string with_rotor_coupling(std::string scene, const std::string& coupling) {
  const std::string key = "compensate_link_inertia: true}";
  scene.replace(scene.find(key), key.size(),
                "compensate_link_inertia: true, rotor_coupling: " + coupling + "}");
  return scene;
}

// The armature approximation drops exactly the rotor's coupling to the previous body:
// T_exact - T_armature = sum_i I_m (Omega_{i-1} qd_m_i + Omega_{i-1}^2 / 2).
TEST(SymbolicIdentities, ArmatureDropsOnlyTheRotorCoupling) {
  const std::string exact = three_geared_links();
  const std::string armature = with_rotor_coupling(exact, "armature");
  const SymbolicModel e = derive(parse_scene(exact, "exact.yaml"));
  const SymbolicModel a = derive(parse_scene(armature, "armature.yaml"));
  ASSERT_TRUE(a.scene.gears[0]->armature);
  const GiNaC::ex Im = e.parameters[1];
  GiNaC::ex coupling = 0;
  for (int i = 1; i <= 3; ++i)
    coupling += Im * (e.omega[i - 1] * e.qd[2 + i] + e.omega[i - 1] * e.omega[i - 1] / 2);
  // Same symbol names, different symbol objects: compare through the names.
  GiNaC::exmap to_e;
  for (int i = 0; i < e.n(); ++i) to_e[a.q[i]] = e.q[i], to_e[a.qd[i]] = e.qd[i];
  for (size_t i = 0; i < a.parameters.size(); ++i) to_e[a.parameters[i]] = e.parameters[i];
  const GiNaC::ex difference = (e.kinetic_energy - a.kinetic_energy.subs(to_e) - coupling).expand();
  EXPECT_TRUE(difference.is_zero()) << difference;
  EXPECT_FALSE(coupling.expand().is_zero());
  // So the last motor's diagonal entry (no later rotor rides on it) and the base's linear
  // block are unchanged, while the base angle couples to the first motor only when exact.
  auto same = [&](int i, int j) {
    return (e.expression(Output::mass_matrix)(i, j) -
            a.expression(Output::mass_matrix)(i, j).subs(to_e))
        .expand()
        .is_zero();
  };
  EXPECT_TRUE(same(5, 5));
  EXPECT_TRUE(same(0, 0) && same(0, 1) && same(1, 1));
  EXPECT_FALSE(same(2, 3));
  EXPECT_FALSE(same(3, 3));  // I_m / p^2 of the second rotor riding on link 1
}

// rotor_coupling: c (issue 29): one scene with a coupling factor is the exact model at c = 1
// and the armature model at c = 0, exactly (T and M, symbolically); the factor makes the
// formulation closed, and its run-time range [0, 1] is checked by the generated code.
TEST(SymbolicIdentities, CouplingFactorSpansExactAndArmature) {
  const std::string exact = three_geared_links();
  auto with = [&](const std::string& coupling) { return with_rotor_coupling(exact, coupling); };
  std::string factor = with("c");
  factor.replace(factor.find("parameters: {"), 13, "parameters: {c: 0.5, ");
  const SymbolicModel e = derive(parse_scene(exact, "exact.yaml"));
  const SymbolicModel a = derive(parse_scene(with("armature"), "armature.yaml"));
  const SymbolicModel f = derive(parse_scene(factor, "factor.yaml"));
  ASSERT_TRUE(f.scene.gears[0]->coupling.has_value());
  EXPECT_EQ(f.scene.formulation, Formulation::closed);
  // Compare through the names: f's parameters are e's plus c.
  auto in = [&](const SymbolicModel& m, double c) {
    GiNaC::exmap to_e;
    for (int i = 0; i < e.n(); ++i) to_e[f.q[i]] = m.q[i], to_e[f.qd[i]] = m.qd[i];
    for (size_t i = 0; i < f.parameters.size(); ++i) {
      const std::string name = GiNaC::ex_to<GiNaC::symbol>(f.parameters[i]).get_name();
      if (name == "c") {
        to_e[f.parameters[i]] = GiNaC::numeric(static_cast<long>(c));
        continue;
      }
      for (size_t k = 0; k < m.parameters.size(); ++k)
        if (GiNaC::ex_to<GiNaC::symbol>(m.parameters[k]).get_name() == name)
          to_e[f.parameters[i]] = m.parameters[k];
    }
    return to_e;
  };
  for (const auto& [model, c] : {std::pair{&e, 1.0}, std::pair{&a, 0.0}}) {
    const GiNaC::exmap to = in(*model, c);
    EXPECT_TRUE((f.kinetic_energy.subs(to) - model->kinetic_energy).expand().is_zero()) << c;
    for (int i = 0; i < e.n(); ++i)
      for (int j = 0; j < e.n(); ++j)
        EXPECT_TRUE((f.expression(Output::mass_matrix)(i, j).subs(to) -
                     model->expression(Output::mass_matrix)(i, j))
                        .expand()
                        .is_zero())
            << "c = " << c << ", M[" << i << "][" << j << "]";
  }
  // Out of [0, 1] in the scene, or with the recursive formulation: named errors.
  for (const auto& [text, want] :
       {std::pair{with("1.5"), "rotor_coupling"}, std::pair{with("sideways"), "rotor_coupling"},
        std::pair{factor + "formulation: recursive\n", "needs the closed form"}}) {
    try {
      parse_scene(text, "bad.yaml");
      ADD_FAILURE() << "accepted: " << want;
    } catch (const std::exception& err) {
      EXPECT_NE(std::string(err.what()).find(want), std::string::npos) << err.what();
    }
  }
}

TEST(SymbolicEntries, GearRatiosAppearAsTheyShould) {
  const SymbolicModel m = derive(parse_scene(test::random_scene_yaml([] {
                                               ChainSpec s;
                                               s.geared = s.gear_parameters = true;
                                               return s;
                                             }()),
                                             "r.yaml"));
  const GiNaC::symbol& p = m.parameters[0];
  // Joint-joint block scales as 1/(p_i p_j), base-joint block as 1/p (MODEL-NOTES).
  EXPECT_EQ(m.expression(Output::mass_matrix)(0, 3).degree(p), -1);
  EXPECT_EQ(m.expression(Output::mass_matrix)(0, 3).ldegree(p), -1);
  EXPECT_EQ(m.expression(Output::mass_matrix)(4, 5).ldegree(p), -2);
  // The rotor of joint 3 couples to the rotation of body 2 (eq. 11): Im/p.
  EXPECT_EQ(m.expression(Output::mass_matrix)(4, 5).degree(p), -1);
  // The motor's own rotor inertia Im is not scaled at all.
  EXPECT_EQ(m.expression(Output::mass_matrix)(5, 5).degree(p), 0);
  EXPECT_EQ(m.expression(Output::mass_matrix)(5, 5).ldegree(p), -2);
  EXPECT_THROW(symbolic_entry(m, "M[6][0]"), std::invalid_argument);
  EXPECT_THROW_MESSAGE(symbolic_entry(m, "Q[0]"), std::invalid_argument,
                       "inspect what it is made of: M (mass_matrix)");
  EXPECT_THROW_MESSAGE(symbolic_entry(m, "Z[0]"), std::invalid_argument, "unknown quantity 'Z'");
  // Wrong index counts and hostile lengths: clear errors, no silent acceptance, no crash
  // (the regular expression this replaced recursed once per character).
  EXPECT_THROW_MESSAGE(symbolic_entry(m, "T[5]"), std::invalid_argument,
                       "T takes 0 indices, got 1");
  EXPECT_THROW_MESSAGE(symbolic_entry(m, "M[1]"), std::invalid_argument,
                       "M takes 2 indices, got 1");
  EXPECT_THROW_MESSAGE(symbolic_entry(m, "b[1][2]"), std::invalid_argument,
                       "b takes 1 index, got 2");
  EXPECT_THROW_MESSAGE(symbolic_entry(m, std::string(1000000, 'M')), std::invalid_argument,
                       "too long");
  EXPECT_THROW(symbolic_entry(m, "M[1][2]x"), std::invalid_argument);
  EXPECT_THROW(symbolic_entry(m, "M[99999999][0]"), std::invalid_argument);
  EXPECT_TRUE(symbolic_entry(m, " M [ 4 ] [5] ").is_equal(m.expression(Output::mass_matrix)(4, 5)));
  // Momentum of a fixed base is not defined (it printed 0 before).
  DeriveOptions all;
  all.all_outputs = true;
  const SymbolicModel fixed =
      derive(load_scene(SPACEARM_SOURCE_DIR "/tests/scenes/fixed_n1.yaml"), all);
  EXPECT_THROW_MESSAGE(symbolic_entry(fixed, "h[0]"), std::invalid_argument,
                       "only defined for a free_floating base");
  // Every closed form of the registry can be inspected (all_outputs derives them all).
  for (const OutputInfo& o : output_registry())
    if (o.composed_of.empty() && (o.needs & ~needs::rigid_joints) == 0) {
      EXPECT_EQ(fixed.outputs.count(o.id), 1u) << o.name;
    }
  // Past the closed form's reach, every closed form is refused by name (unless forced).
  test::ChainSpec spec;
  spec.links = kClosedFormLinks + 1;
  spec.outputs = "[mass_matrix]";
  const Scene long_chain = parse_scene(test::random_scene_yaml(spec), "long.yaml");
  EXPECT_THROW_MESSAGE(derive(long_chain, all), std::invalid_argument,
                       "has 9 links: the closed form's entries are printed up to 8 links");
  EXPECT_THROW_MESSAGE(derive(long_chain, all), std::invalid_argument, "formulation: closed");
  // One coordinate: M is still a matrix, b and J keep their indices.
  EXPECT_TRUE(
      symbolic_entry(fixed, "M[0][0]").is_equal(fixed.expression(Output::mass_matrix)(0, 0)));
  EXPECT_NO_THROW(symbolic_entry(fixed, "b[0]"));
  EXPECT_NO_THROW(symbolic_entry(fixed, "qj[0]"));
  EXPECT_THROW_MESSAGE(symbolic_entry(fixed, "M[0]"), std::invalid_argument,
                       "M takes 2 indices, got 1");
  EXPECT_TRUE(symbolic_entry(m, "M[4][5]").is_equal(m.expression(Output::mass_matrix)(4, 5)));
}

}  // namespace
}  // namespace spacearm
