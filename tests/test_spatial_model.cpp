// generator/spatial_model.hpp: a spatial arm goes through the stages the plane uses (lowering
// with its self-check, the printer, the C interface) from its derived model alone, and the
// lowered programs give the spatial chain's values at any state.
#include "spatial_model.hpp"

#include <algorithm>
#include <random>

#include "cpp_printer.hpp"
#include "lowering.hpp"
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
  // Without `outputs:` the defaults, as in the plane: all but the state Jacobian.
  std::string defaults = kArm;
  defaults.erase(defaults.find("outputs:"));
  const std::vector<Output> by_default = spatial_outputs(parse_spatial_scene(defaults, "arm3"));
  // M, C, b, T, momentum, ID, FD, the pose and its Jacobian, J*, free-base ID (not Mdot).
  EXPECT_EQ(by_default.size(), 11u);
  EXPECT_EQ(std::count(by_default.begin(), by_default.end(), Output::mass_matrix_derivative), 0);
  for (Output o : {Output::coriolis_matrix, Output::end_effector_jacobian,
                   Output::generalized_jacobian, Output::free_base_inverse_dynamics})
    EXPECT_EQ(std::count(by_default.begin(), by_default.end(), o), 1) << to_string(o);
  EXPECT_EQ(std::count(by_default.begin(), by_default.end(), Output::forward_dynamics_derivatives),
            0);
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

}  // namespace
}  // namespace spacearm
