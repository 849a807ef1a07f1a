// generator/derive/spatial/spatial_model.hpp: a spatial arm goes through the stages the plane uses
// (lowering with its self-check, the printer, the C interface) from its derived model alone, and
// the lowered programs give the spatial chain's values at any state.
#include "spatial_model.hpp"

#include <algorithm>
#include <map>
#include <optional>
#include <random>
#include <regex>

#include "cpp_printer.hpp"
#include "lowering.hpp"
#include "model_recipe.hpp"
#include "program_expression.hpp"
#include "recursive_algorithms.hpp"
#include "spatial_chain.hpp"
#include "support.hpp"

namespace spacearm {
namespace {

const std::string kArm = R"(name: arm3
space: spatial
base: {type: free_floating, mass: 500, com: [0.1, 0, 0], inertia: [100, 0, 0, 120, 0, 150]}
links:
  - {origin: [0.5, 0, 0.2], axis: [0, 0, 1], mass: 5, com: [0.2, 0, 0],
     inertia: [0.01, 0, 0, 0.2, 0, 0.2]}
  - {origin: [0.4, 0, 0], rpy: [1.5707963, 0, 0], axis: [0, 0, 1], mass: 3, com: [0.2, 0, 0],
     inertia: [0.01, 0.001, 0, 0.1, 0, 0.1]}
  - {origin: [0.3, 0, 0], axis: [0, 1, 0], mass: 2, com: [0.1, 0.01, 0],
     inertia: [0.01, 0, 0, 0.05, 0, 0.05]}
gears:
  - {ratio: 100, rotor_inertia: [1.0e-4, 6.0e-5], rotor_coupling: exact}
  - {ratio: 50, rotor_inertia: [2.0e-4, 1.0e-4], rotor_coupling: armature}
  - {ratio: 1, rotor_inertia: [0, 0]}
outputs: [forward_dynamics_derivatives, mass_matrix, bias_forces, kinetic_energy, momentum,
          inverse_dynamics, forward_dynamics]
)";

TEST(SpatialModel, LowersAndPrintsFromTheDerivedModelAlone) {
  const SpatialScene scene = parse_spatial_scene(kArm, "arm3.yaml");
  const LoweredModel lowered = lower(spatial_derived_model(scene), {});
  EXPECT_EQ(lowered.facts.dims.nq, 10);
  EXPECT_EQ(lowered.facts.dims.nv, 9);
  EXPECT_TRUE(lowered.facts.dims.spatial);
  std::vector<std::string> names;
  for (const FunctionSpec& f : lowered.functions) names.push_back(f.name);
  EXPECT_EQ(names, (std::vector<std::string>{"mass_matrix", "bias_forces", "mass_matrix_and_bias",
                                             "kinetic_energy", "momentum", "inverse_dynamics",
                                             "forward_dynamics", "forward_dynamics_derivatives",
                                             "gear_ratios"}));
  // Without `outputs:` the defaults, as in the plane past the closed forms' reach: all but the
  // state Jacobian, C and Mdot.
  std::string defaults = kArm;
  defaults.erase(defaults.find("outputs:"));
  const std::vector<Output> by_default = spatial_outputs(parse_spatial_scene(defaults, "arm3"));
  // M, b, T, momentum, ID, FD, the pose and its Jacobian, the joints' positions, the link-side
  // joint angles and rates, J*, free-base ID.
  EXPECT_EQ(by_default.size(), 13u);
  for (Output o : {Output::mass_matrix, Output::end_effector_jacobian, Output::generalized_jacobian,
                   Output::free_base_inverse_dynamics})
    EXPECT_EQ(std::count(by_default.begin(), by_default.end(), o), 1) << to_string(o);
  for (Output o : {Output::coriolis_matrix, Output::mass_matrix_derivative,
                   Output::forward_dynamics_derivatives})
    EXPECT_EQ(std::count(by_default.begin(), by_default.end(), o), 0) << to_string(o);
  const EmittedModel e = print_cpp(lowered, {});
  for (const char* fact :
       {"inline constexpr int kNq = 10;", "inline constexpr int kNv = 9;",
        "inline constexpr int kNumBase = 6;", "inline constexpr int kQuaternionOffset = 3;",
        "kMotorAngleSlots = {true, true, true};", "\"qw0\", \"qx0\", \"qy0\", \"qz0\""})
    EXPECT_NE(e.header.find(fact), std::string::npos) << fact;
  EXPECT_NE(e.c_interface.find("int spacearm_configuration_layout() { return 3; }"),
            std::string::npos);
}

// The lowered (CSE'd) programs of forward dynamics and momentum at random states, against the
// chain run in double.
TEST(SpatialModel, LoweredProgramsGiveTheChainsValues) {
  const SpatialScene scene = parse_spatial_scene(kArm, "arm3.yaml");
  const LoweredModel lowered = lower(spatial_derived_model(scene), {});
  std::mt19937 rng(40);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 3; ++trial) {
    std::vector<double> q(10), v(9), Q(9);
    for (double& x : q) x = u(rng);
    for (double& x : v) x = u(rng);
    for (double& x : Q) x = u(rng);
    double n = 0;
    for (int k = 3; k < 7; ++k) n += q[k] * q[k];
    for (int k = 3; k < 7; ++k) q[k] /= std::sqrt(n);
    auto input = [&](const std::string& a, int i) {
      return a == "q" ? q[i] : a == "qd" ? v[i] : a == "Q" ? Q[i] : 0.0;
    };
    for (const FunctionSpec& f : lowered.functions) {
      if (f.name != "forward_dynamics" && f.name != "momentum") continue;
      const Output o = f.name == "momentum" ? Output::momentum : Output::forward_dynamics;
      const std::vector<double> want = evaluate_chain<spatial::Chain>(scene.chain, o, input)[0];
      const std::vector<double> got = f.program.evaluate(f.entries[0], input);
      ASSERT_EQ(got.size(), want.size());
      for (size_t k = 0; k < want.size(); ++k)
        EXPECT_NEAR(got[k], want[k], 1e-12 * (1 + std::abs(want[k]))) << f.name << " " << k;
    }
  }
}

// N = 30 in 3D, as in the plane: a 30-joint arm with exact rotors (ratio a run-time parameter)
// lowers, and its programs give the chain's values at a random state. Cost: about 1 s.
// (Compiled, `spacearm simulate --zero` of it for 1 s by rkf78 kept the momentum to 5e-14.)
TEST(SpatialModel, ThirtyJointsLowerAndGiveTheChainsValues) {
  std::string scene =
      "name: arm30\nspace: spatial\nbase: {type: free_floating, mass: 800, com: [0.1, 0, 0], "
      "inertia: [200, 0, 0, 220, 0, 250]}\nlinks:\n";
  for (int i = 0; i < 30; ++i)
    scene += std::string("  - {origin: [0.3, 0, 0.05], rpy: [") + (i % 2 ? "" : "-") +
             "1.5707963, 0, 0], axis: [0, 0, 1], mass: " + std::to_string(3 - 0.05 * i) +
             ", com: [0.15, 0, 0], inertia: [0.01, 0, 0, 0.05, 0, 0.05]}\n";
  scene +=
      "gears: {ratio: p, rotor_inertia: [1.0e-4, 6.0e-5], rotor_coupling: exact}\n"
      "parameters: {p: 100}\noutputs: [mass_matrix, bias_forces, forward_dynamics, momentum]\n";
  const SpatialScene s = parse_spatial_scene(scene, "arm30.yaml");
  const LoweredModel lowered = lower(spatial_derived_model(s), {});
  EXPECT_EQ(lowered.facts.dims.nv, 36);
  std::mt19937 rng(43);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> q(37), v(36), Q(36);
  for (double& x : q) x = u(rng);
  for (double& x : v) x = u(rng);
  for (double& x : Q) x = u(rng);
  auto input = [&](const std::string& a, int i) {
    return a == "q" ? q[i] : a == "qd" ? v[i] : a == "Q" ? Q[i] : a == "params" ? 37.0 : 0.0;
  };
  int checked = 0;
  for (const FunctionSpec& f : lowered.functions) {
    const std::optional<Output> o = output_from_string(f.name);
    if (!o || (!s.outputs.empty() && !std::count(s.outputs.begin(), s.outputs.end(), *o))) continue;
    const std::vector<double> want = evaluate_chain<spatial::Chain>(s.chain, *o, input)[0];
    const std::vector<double> got = f.program.evaluate(f.entries[0], input);
    ASSERT_EQ(got.size(), want.size()) << f.name;
    for (size_t k = 0; k < want.size(); ++k)
      EXPECT_NEAR(got[k], want[k], 1e-10 * (1 + std::abs(want[k]))) << f.name << " " << k;
    ++checked;
  }
  EXPECT_EQ(checked, 4);
}

// inspect's closed forms in 3D: each entry's recorded program expanded into one expression
// (program_expression.hpp) is, evaluated by GiNaC at a random state, the program's value; an
// entry past the budget has none (nullopt), and inspect then prints its statements, and refuses
// LaTeX by name.
TEST(SpatialModel, ClosedFormsOfEntriesAreTheirPrograms) {
  const SpatialScene scene = parse_spatial_scene(kArm, "arm3.yaml");
  const LoweredModel lowered = lower(spatial_derived_model(scene), {});
  std::mt19937 rng(45);
  std::uniform_real_distribution<double> u(-1, 1);
  std::map<std::pair<std::string, int>, double> at;
  auto input = [&](const std::string& a, int i) {
    return at.try_emplace({a, i}, u(rng)).first->second;
  };
  std::map<std::pair<std::string, int>, GiNaC::symbol> symbols;
  auto symbol = [&](const std::string& a, int i) -> GiNaC::ex {
    return symbols.try_emplace({a, i}, GiNaC::symbol(a + std::to_string(i))).first->second;
  };
  int closed = 0, open = 0;
  for (const FunctionSpec& f : lowered.functions) {
    if (f.name == "forward_dynamics_derivatives" || f.name == "mass_matrix_and_bias") continue;
    for (const SRef& root : f.entries[0]) {
      const double want = f.program.evaluate({root}, input)[0];
      const std::optional<GiNaC::ex> x = expanded_expression(f.program, root, symbol, 400);
      if (!x) {
        ++open;
        continue;
      }
      GiNaC::exmap values;
      for (const auto& [key, s] : symbols) values[s] = input(key.first, key.second);
      const double got = GiNaC::ex_to<GiNaC::numeric>(GiNaC::evalf(x->subs(values))).to_double();
      EXPECT_NEAR(got, want, 1e-12 * (1 + std::abs(want))) << f.name;
      ++closed;
    }
  }
  EXPECT_GT(closed, 50);  // M, T, the momentum's entries of this 3-joint arm
  EXPECT_GT(open, 0);     // forward dynamics' entries (a solve) pass the budget
  const ModelRecipe recipe(scene);
  EXPECT_NE(recipe.inspect_entry("M[6][7]").find("cos("), std::string::npos);
  EXPECT_NE(recipe.inspect_entry("M[6][7]", true).find("\\cos"), std::string::npos);
  EXPECT_EQ(recipe.inspect_entry("qdd[0]").rfind("// qdd[0] of forward_dynamics", 0), 0u);
  EXPECT_THROW_MESSAGE(recipe.inspect_entry("qdd[0]", true), std::invalid_argument,
                       "entry 'qdd[0]': LaTeX and decimals need a closed form");
}

// kArm with run-time parameters for a ratio of each coupling, the rotor inertias, the base's and
// a link's mass, centre and inertia entries; and kArm itself with the values P written in.
const std::string kParametric = R"(name: arm3
space: spatial
base: {type: free_floating, mass: mb, com: [cb, 0, 0], inertia: [100, 0, 0, 120, 0, izb]}
links:
  - {origin: [0.5, 0, 0.2], axis: [0, 0, 1], mass: 5, com: [0.2, 0, 0],
     inertia: [0.01, 0, 0, 0.2, 0, 0.2]}
  - {origin: [0.4, 0, 0], rpy: [1.5707963, 0, 0], axis: [0, 0, 1], mass: m2, com: [0.2, 0, 0],
     inertia: [0.01, ixy2, 0, 0.1, 0, 0.1]}
  - {origin: [0.3, 0, 0], axis: [0, 1, 0], mass: 2, com: [0.1, cy3, 0],
     inertia: [0.01, 0, 0, 0.05, 0, 0.05]}
gears:
  - {ratio: p1, rotor_inertia: [Ia1, It1], rotor_coupling: exact}
  - {ratio: p2, rotor_inertia: [Ia2, 1.0e-4], rotor_coupling: armature}
  - {ratio: 1, rotor_inertia: [0, 0]}
friction:
  - {viscous: fv1, coulomb: fc1, velocity_scale: vs1, stribeck_static: fs1, stribeck_velocity: vst1}
  - null
  - {viscous: 0.01, coulomb: 0.02, velocity_scale: 0.3}
parameters: {mb: 500, cb: 0.1, izb: 150, m2: 3, ixy2: 0.001, cy3: 0.01, p1: 100, Ia1: 1.0e-4,
             It1: 6.0e-5, p2: 50, Ia2: 2.0e-4, fv1: 0.01, fc1: 0.1, vs1: 0.2, fs1: 0.15, vst1: 0.5}
outputs: [forward_dynamics_derivatives, mass_matrix, coriolis_matrix, bias_forces, kinetic_energy,
          momentum, inverse_dynamics, forward_dynamics, end_effector_pose, end_effector_jacobian,
          generalized_jacobian, free_base_inverse_dynamics, friction_forces]
)";

// The parametric model at parameter values P is the model with P written in as numbers: every
// output's lowered program at random states (so no nominal value is baked into the code).
void expect_parameters_written_in(const std::string& parametric,
                                  const std::vector<std::pair<std::string, std::string>>& P) {
  std::string literal = parametric;
  literal.erase(literal.find("parameters:"),
                literal.find("outputs:") - literal.find("parameters:"));
  std::vector<double> params;
  for (const auto& [name, value] : P) {
    params.push_back(std::stod(value));
    const std::regex word("\\b" + name + "\\b");
    literal = std::regex_replace(literal, word, value);
  }
  const SpatialScene with_parameters = parse_spatial_scene(parametric, "arm3p.yaml");
  const SpatialScene with_numbers = parse_spatial_scene(literal, "arm3.yaml");
  ASSERT_EQ(with_parameters.parameters.size(), P.size());
  const LoweredModel a = lower(spatial_derived_model(with_parameters), {});
  const LoweredModel b = lower(spatial_derived_model(with_numbers), {});
  ASSERT_EQ(a.functions.size(), b.functions.size());
  std::mt19937 rng(41);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 3; ++trial) {
    std::vector<double> q(a.facts.dims.nq), v(a.facts.dims.nv);
    for (double& x : q) x = u(rng);
    for (double& x : v) x = u(rng);
    auto input = [&](const std::string& array, int i) {
      return array == "q"        ? q[i]
             : array == "qd"     ? v[i]
             : array == "params" ? params.at(i)
                                 : 0.3 * std::cos(i);
    };
    for (size_t f = 0; f < a.functions.size(); ++f) {
      ASSERT_EQ(a.functions[f].name, b.functions[f].name);
      for (size_t r = 0; r < a.functions[f].entries.size(); ++r) {
        const auto got = a.functions[f].program.evaluate(a.functions[f].entries[r], input);
        const auto want = b.functions[f].program.evaluate(b.functions[f].entries[r], input);
        ASSERT_EQ(got.size(), want.size());
        for (size_t k = 0; k < want.size(); ++k)
          EXPECT_NEAR(got[k], want[k], 1e-11 * (1 + std::abs(want[k])))
              << a.functions[f].name << " result " << r << " entry " << k;
      }
    }
  }
}

TEST(SpatialModel, RunTimeParametersGiveTheModelWithTheirValuesWrittenIn) {
  expect_parameters_written_in(kParametric, {{"mb", "420"},
                                             {"cb", "-0.07"},
                                             {"izb", "170"},
                                             {"m2", "4.5"},
                                             {"ixy2", "-0.02"},
                                             {"cy3", "0.03"},
                                             {"p1", "37"},
                                             {"Ia1", "3.0e-4"},
                                             {"It1", "1.0e-5"},
                                             {"p2", "8"},
                                             {"Ia2", "5.0e-4"},
                                             {"fv1", "0.03"},
                                             {"fc1", "0.2"},
                                             {"vs1", "0.7"},
                                             {"fs1", "0.25"},
                                             {"vst1", "0.3"}});
}

// kArm with flexible joints 1 (exact rotor, a spring and a damper) and 2 (armature, a spring),
// joint 3 a rigid gear; friction on joint 1's motor.
std::string flexible_arm(const std::string& gear1, const std::string& stiffness2) {
  std::string text = kArm;
  text.replace(text.find("gears:"), text.find("outputs:") - text.find("gears:"),
               "gears:\n  - " + gear1 +
                   "\n  - {ratio: 50, rotor_inertia: [2.0e-4, 1.0e-4], rotor_coupling: armature, "
                   "stiffness: " +
                   stiffness2 +
                   "}\n  - {ratio: 20, rotor_inertia: [1.0e-5, 1.0e-5]}\nfriction: [{viscous: "
                   "0.01, coulomb: 0.02, velocity_scale: 0.3}, null, null]\n");
  return text.substr(0, text.find("outputs:"));
}

// A flexible arm's model: the link angles in the joint slots and the motors after them (the
// header's facts), the springs' outputs by default and the rigid-joint ones refused, and every
// lowered program gives the chain's values at random states.
TEST(SpatialModel, AFlexibleArmHasItsMotorsAfterTheJointsAndItsSprings) {
  const SpatialScene scene = parse_spatial_scene(
      flexible_arm("{ratio: 100, rotor_inertia: [1.0e-4, 6.0e-5], stiffness: 2000, damping: 0.5}",
                   "800"),
      "arm3f.yaml");
  const LoweredModel lowered = lower(spatial_derived_model(scene), {});
  EXPECT_EQ(lowered.facts.dims.nq, 12);
  EXPECT_EQ(lowered.facts.dims.nv, 11);
  const std::vector<std::string> names = {"x0",  "y0", "z0", "qw0", "qx0", "qy0",
                                          "qz0", "q1", "q2", "qm3", "qm1", "qm2"};
  EXPECT_EQ(lowered.facts.coordinate_names, names);
  const EmittedModel e = print_cpp(lowered, {});
  for (const char* fact :
       {"kActuatedCoordinates = {9, 10, 8};", "kMotorAngleSlots = {false, false, true};"})
    EXPECT_NE(e.header.find(fact), std::string::npos) << fact;
  const std::vector<Output> outputs = spatial_outputs(scene);
  for (Output o : {Output::potential_energy, Output::spring_damper_forces, Output::friction_forces})
    EXPECT_EQ(std::count(outputs.begin(), outputs.end(), o), 1) << to_string(o);
  for (Output o : {Output::generalized_jacobian, Output::free_base_inverse_dynamics})
    EXPECT_EQ(std::count(outputs.begin(), outputs.end(), o), 0) << to_string(o);
  EXPECT_THROW_MESSAGE(
      parse_spatial_scene(
          flexible_arm("{ratio: 100, rotor_inertia: [1.0e-4, 6.0e-5], stiffness: 2000}", "800") +
              "outputs: [generalized_jacobian]\n",
          "arm3f.yaml"),
      SceneError, "'generalized_jacobian' is not defined for a scene with flexible joints");
  std::mt19937 rng(44);
  std::uniform_real_distribution<double> u(-1, 1);
  int checked = 0;
  for (int trial = 0; trial < 3; ++trial) {
    std::vector<double> q(12), v(11), a(11), Q(11);
    for (auto* x : {&q, &v, &a, &Q})
      for (double& y : *x) y = u(rng);
    auto input = [&](const std::string& name, int i) {
      return name == "q" ? q[i] : name == "qd" ? v[i] : name == "qdd" ? a[i] : Q[i];
    };
    for (const FunctionSpec& f : lowered.functions) {
      const std::optional<Output> o = output_from_string(f.name);
      if (!o) continue;  // mass_matrix_and_bias, gear_ratios
      const auto want = evaluate_chain<spatial::Chain>(scene.chain, *o, input);
      for (size_t r = 0; r < want.size(); ++r) {
        const std::vector<double> got = f.program.evaluate(f.entries[r], input);
        ASSERT_EQ(got.size(), want[r].size());
        for (size_t k = 0; k < got.size(); ++k)
          EXPECT_NEAR(got[k], want[r][k], 1e-12 * (1 + std::abs(want[r][k])))
              << f.name << " " << r << " " << k;
      }
      ++checked;
      // The link-side joint angles and rates: the flexible joints' slots as they are, the rigid
      // gear's (joint 3, p = 20) divided by its ratio.
      if (*o == Output::joint_angles || *o == Output::joint_rates) {
        const std::vector<double>& x = *o == Output::joint_angles ? q : v;
        const int slot = *o == Output::joint_angles ? 7 : 6;
        EXPECT_EQ(f.program.evaluate(f.entries[0], input),
                  (std::vector<double>{x[slot], x[slot + 1], x[slot + 2] * (1 / 20.0)}));
      }
    }
  }
  EXPECT_GE(checked, 3 * 13);
}

// Issue 51: rotor_coupling: c in 3D as in the plane. One compiled model is the exact model at
// c = 1 and the armature model at c = 0 (every lowered output against the literal scene's, which
// reads 1 as exact and 0 as armature), and a literal factor between at c = 0.4; the generated
// rules keep c in [0, 1]; a literal out of range, a word, or a flexible joint are refused.
TEST(SpatialModel, ARotorCouplingFactorSpansExactAndArmature) {
  std::string coupled = kArm;
  for (const char* kind : {"rotor_coupling: exact", "rotor_coupling: armature"})
    coupled.replace(coupled.find(kind), std::string(kind).size(), "rotor_coupling: c");
  coupled.replace(coupled.find("outputs:"), 0, "parameters: {c: 0.5}\n");
  for (const char* c : {"1", "0", "0.4"}) {
    SCOPED_TRACE(std::string("c = ") + c);
    expect_parameters_written_in(coupled, {{"c", c}});
  }
  const ModelFacts facts = spatial_facts(parse_spatial_scene(coupled, "arm3c.yaml"));
  auto failure = [&](double c) -> std::string {
    for (const ParameterCheck& check : facts.checks) {
      const double v = facts.checks_program.evaluate({check.value},
                                                     [&](const std::string&, int) { return c; })[0];
      if (!(check.strict ? v > 0 : v >= 0)) return check.message;
    }
    return "";
  };
  EXPECT_EQ(failure(0), "");
  EXPECT_EQ(failure(1), "");
  EXPECT_EQ(failure(-0.01), "gears[0].rotor_coupling must be in [0, 1] (not negative)");
  EXPECT_EQ(failure(1.01), "gears[0].rotor_coupling must be in [0, 1] (not above 1)");
  const std::string flexible = flexible_arm(
      "{ratio: 100, rotor_inertia: [1.0e-4, 6.0e-5], rotor_coupling: 0.5, "
      "stiffness: 800}",
      "600");
  for (const auto& [text, want] :
       {std::pair{std::regex_replace(coupled, std::regex("c: 0.5"), "c: 1.5"),
                  "gears[0].rotor_coupling': expected exact, armature or a coupling factor in [0, "
                  "1] (1 exact, 0 armature), got c = 1.5"},
        std::pair{std::regex_replace(coupled, std::regex("rotor_coupling: c"),
                                     "rotor_coupling: sideways"),
                  "a parameter declared under 'parameters'), got 'sideways'"},
        std::pair{flexible, "a coupling factor needs a rigid gear"}}) {
    try {
      parse_spatial_scene(text, "bad.yaml");
      ADD_FAILURE() << "accepted: " << want;
    } catch (const SceneError& e) {
      EXPECT_NE(std::string(e.what()).find(want), std::string::npos) << e.what();
    }
  }
}

// A flexible arm's springs, dampers and rotor as run-time parameters.
TEST(SpatialModel, AFlexibleArmsRunTimeParametersGiveItsModelWithTheirValuesWrittenIn) {
  const std::string parametric =
      flexible_arm("{ratio: p1, rotor_inertia: [Ia1, It1], stiffness: k1, damping: d1}", "k2") +
      "parameters: {p1: 100, Ia1: 1.0e-4, It1: 6.0e-5, k1: 2000, d1: 0.5, k2: 800}\n";
  expect_parameters_written_in(parametric, {{"p1", "37"},
                                            {"Ia1", "3.0e-4"},
                                            {"It1", "1.0e-5"},
                                            {"k1", "900"},
                                            {"d1", "0.05"},
                                            {"k2", "3000"}});
  const ModelFacts facts = spatial_facts(parse_spatial_scene(parametric, "arm3f.yaml"));
  auto first_failure = [&](const std::string& name, double value) -> std::string {
    std::vector<double> params = facts.nominal_parameters;
    const auto& names = facts.parameter_names;
    params[std::find(names.begin(), names.end(), name) - names.begin()] = value;
    for (const ParameterCheck& c : facts.checks) {
      const double x = facts.checks_program.evaluate(
          {c.value}, [&](const std::string&, int i) { return params.at(i); })[0];
      if (!(c.strict ? x > 0 : x >= 0)) return c.message;
    }
    return "";
  };
  EXPECT_EQ(first_failure("k1", 1), "");
  EXPECT_EQ(first_failure("k1", 0), "gears[0].stiffness must be positive");
  EXPECT_EQ(first_failure("d1", -1e-9), "gears[0].damping must not be negative");
  EXPECT_EQ(first_failure("k2", -5), "gears[1].stiffness must be positive");
  EXPECT_EQ(first_failure("Ia1", 0), "gears[0].rotor_inertia[0] must be positive");
}

// The scene's range rules hold at the nominal values and are checked again at run time for the
// parameters' values (the generated parameter_error()), naming the field.
TEST(SpatialModel, RunTimeParametersAreCheckedByTheScenesRules) {
  const ModelFacts facts = spatial_facts(parse_spatial_scene(kParametric, "arm3p.yaml"));
  const std::vector<std::string>& names = facts.parameter_names;
  auto first_failure = [&](const std::map<std::string, double>& changed) -> std::string {
    std::vector<double> params = facts.nominal_parameters;
    for (const auto& [name, value] : changed)
      params[std::find(names.begin(), names.end(), name) - names.begin()] = value;
    auto input = [&](const std::string&, int i) { return params.at(i); };
    for (const ParameterCheck& c : facts.checks) {
      const double v = facts.checks_program.evaluate({c.value}, input)[0];
      if (!(c.strict ? v > 0 : v >= 0)) return c.message;
    }
    return "";
  };
  EXPECT_EQ(first_failure({}), "");
  EXPECT_EQ(first_failure({{"mb", 0}}), "base.mass must be positive");
  EXPECT_EQ(first_failure({{"m2", -1}}), "links[1].mass must be positive");
  EXPECT_EQ(first_failure({{"p2", 0}}), "gears[1].ratio must be positive");
  EXPECT_EQ(first_failure({{"Ia1", -1e-9}}), "gears[0].rotor_inertia[0] must not be negative");
  EXPECT_EQ(first_failure({{"It1", -1e-9}}), "gears[0].rotor_inertia[1] must not be negative");
  const std::string physical =
      " must be a physical inertia (positive definite, principal "
      "moments within the triangle inequality)";
  EXPECT_EQ(first_failure({{"fv1", -1e-9}}), "friction[0].viscous must not be negative");
  EXPECT_EQ(first_failure({{"vs1", 1e-10}}),
            "friction[0].velocity_scale must be at least 1e-9 rad/s");
  EXPECT_EQ(first_failure({{"fs1", 0.05}}),
            "friction[0].stribeck_static must not be below coulomb");
  EXPECT_EQ(first_failure({{"vst1", 0}}),
            "friction[0].stribeck_velocity must be at least 1e-9 rad/s");
  EXPECT_EQ(first_failure({{"izb", 221}}), "base.inertia" + physical);  // 100 + 120 < 221
  EXPECT_EQ(first_failure({{"izb", 220}}), "");                         // a flat plate
  EXPECT_EQ(first_failure({{"izb", -1}}), "base.inertia" + physical);
  EXPECT_EQ(first_failure({{"ixy2", 0.04}}), "links[1].inertia" + physical);   // 0.01 0.1 - ixy^2
  EXPECT_EQ(first_failure({{"cb", 40}, {"ixy2", -0.005}}), "");                // a centre anywhere
  EXPECT_EQ(first_failure({{"ixy2", -0.03}}), "links[1].inertia" + physical);  // triangle
  // The run-time rules accept the tensors the reader accepts (eigenvalues), and no others.
  const std::string one_link = R"(name: one
space: spatial
base: {type: free_floating, mass: 10, inertia: [a, b, c, d, e, f]}
links: [{mass: 1, inertia: [1, 0, 0, 1, 0, 1]}]
)";
  const ModelFacts f =
      spatial_facts(parse_spatial_scene(one_link + "parameters: {a: 1, b: 0, c: 0, d: 1, e: 0, "
                                                   "f: 1}\n",
                                        "one.yaml"));
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(-1, 1);
  int accepted = 0;
  for (int trial = 0; trial < 300; ++trial) {
    std::vector<double> I = {1 + 0.5 * u(rng), 0.3 * u(rng), 0.3 * u(rng), 1 + 0.5 * u(rng),
                             0.3 * u(rng)};
    I.push_back((I[0] + I[3]) * (0.8 + 0.3 * u(rng)));
    std::string literal = one_link;
    const char* names[] = {"a", "b", "c", "d", "e", "f"};
    for (int k = 0; k < 6; ++k)
      literal = std::regex_replace(literal, std::regex(std::string("\\b") + names[k] + "\\b"),
                                   std::to_string(I[k]));
    for (double& x : I) x = std::stod(std::to_string(x));  // the numbers the reader reads
    bool reader_accepts = true;
    try {
      parse_spatial_scene(literal, "one.yaml");
    } catch (const SceneError&) {
      reader_accepts = false;
    }
    bool rules_accept = true;
    for (const ParameterCheck& c : f.checks) {
      const double v = f.checks_program.evaluate(
          {c.value}, [&](const std::string&, int i) { return I.at(i); })[0];
      rules_accept = rules_accept && (c.strict ? v > 0 : v >= 0);
    }
    EXPECT_EQ(rules_accept, reader_accepts) << literal;
    accepted += reader_accepts;
  }
  EXPECT_GT(accepted, 60);
  EXPECT_LT(accepted, 240);
}

// Issue 51: under inertia_check: positive_definite a tensor with a run-time parameter is
// checked for positive definiteness alone (its leading minors): an identified tensor passes, one
// that is not positive definite is named.
TEST(SpatialModel, PositiveDefiniteRuleChecksOnlyTheLeadingMinors) {
  const std::string text = R"(name: one
space: spatial
base: {type: free_floating, mass: 10, inertia: [1, 0, 0, 1, 0, 1]}
links: [{mass: 1, inertia: [0.1, ixy, 0, 0.1, 0, izz]}]
parameters: {izz: 0.15, ixy: 0}
)";
  for (const bool identified : {false, true}) {
    const ModelFacts facts = spatial_facts(parse_spatial_scene(
        text + (identified ? "inertia_check: positive_definite\n" : ""), "one.yaml"));
    EXPECT_EQ(facts.inertia_check, identified ? "positive_definite" : "physical");
    auto failure = [&](double izz, double ixy) -> std::string {
      const std::vector<double> params = {izz, ixy};
      for (const ParameterCheck& c : facts.checks) {
        const double v = facts.checks_program.evaluate(
            {c.value}, [&](const std::string&, int i) { return params.at(i); })[0];
        if (!(c.strict ? v > 0 : v >= 0)) return c.message;
      }
      return "";
    };
    EXPECT_EQ(failure(0.15, 0), "");
    EXPECT_EQ(failure(1.5, 0), identified ? ""
                                          : "links[0].inertia must be a physical inertia "
                                            "(positive definite, principal moments within "
                                            "the triangle inequality)");
    const std::string not_definite =
        identified ? "links[0].inertia must be positive definite"
                   : "links[0].inertia must be a physical inertia (positive definite, principal "
                     "moments within the triangle inequality)";
    EXPECT_EQ(failure(-0.1, 0), not_definite);
    EXPECT_EQ(failure(1.5, 0.2), not_definite);  // 0.1 0.1 - 0.2^2 < 0
  }
}

// Issue 49, item 10: the numbers whose span a failure names include a spatial arm's, a URDF's
// `inertials:` with its run-time parameter among them; the payload's mass taken 26 decades
// below its nominal value widens the span, by field and parameter.
TEST(SpatialModel, TheSpanOfValuesCoversInertialsAndTheirParameters) {
  const SpatialScene scene = parse_spatial_scene(
      test::read_text_file(std::string(SPACEARM_SOURCE_DIR) + "/models/space_arm7_payload.yaml"),
      std::string(SPACEARM_SOURCE_DIR) + "/models/space_arm7_payload.yaml");
  const ModelFacts facts = spatial_facts(scene);
  const auto mp = std::find(facts.parameter_names.begin(), facts.parameter_names.end(), "mp") -
                  facts.parameter_names.begin();
  ASSERT_LT(size_t(mp), facts.parameter_names.size());
  const auto by_mp = std::count_if(facts.span_fields.begin(), facts.span_fields.end(),
                                   [&](const SpanField& f) { return f.parameter == mp; });
  EXPECT_EQ(by_mp, 1);  // the flange's mass; its com and inertia are literals
  std::vector<double> params = facts.nominal_parameters;
  EXPECT_LT(span_decades(facts.span_fields, params.data()), 7);
  params[size_t(mp)] = 1e-26;
  EXPECT_GE(span_decades(facts.span_fields, params.data()), 25);
  const std::string text = value_span(facts.span_fields, params.data(), facts.parameter_names);
  EXPECT_NE(text.find("(mp) = 1e-26 to "), std::string::npos) << text;
  // At the nominal values the span runs from a rotor's inertia to the base's mass; mp is inside.
  const std::string nominal = value_span(facts.span_fields, nullptr, facts.parameter_names);
  EXPECT_NE(nominal.find("from gears[0].rotor_inertia.transverse = 7e-05 to base.mass"),
            std::string::npos)
      << nominal;
  EXPECT_EQ(nominal.find("(mp)"), std::string::npos) << nominal;
}

}  // namespace
}  // namespace spacearm
