// jit/compiled_model.hpp: compile-and-load with a cache; the library states the model's facts,
// the cache is reused for an unchanged scene and rebuilt for a changed or corrupted one, four
// lanes compute what one does, and loaded code equals the linked model. The commands that use it
// are tested in tests/cli/.
#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <signal.h>
#include <spawn.h>

#include "cli_fixtures.hpp"
#include "compiled_model.hpp"
#include "paper_flexible.hpp"
#include "paper_geared.hpp"
#include "paper_reference.hpp"
#include "simulation.hpp"
#include "spatial_model.hpp"
#include "support.hpp"

extern char** environ;

namespace spacearm {
namespace {

namespace fs = std::filesystem;
using test::fresh_cache;
using test::run;

TEST(CompiledModel, CachedSecondLoadNeitherGeneratesNorCompiles) {
  const fs::path cache = fresh_cache("reuse");
  CompileOptions options;
  options.cache_dir = cache.string();
  const Scene scene = load_scene(SPACEARM_SOURCE_DIR "/models/paper_reference.yaml");
  StageReport first, second;
  const CompiledModel a = CompiledModel::load(scene, options, &first);
  EXPECT_TRUE(first.generated);
  EXPECT_TRUE(first.compiled);
  EXPECT_TRUE(fs::exists(fs::path(first.cache_entry) / "COMPLETE"));
  const CompiledModel b = CompiledModel::load(scene, options, &second);
  EXPECT_FALSE(second.generated);
  EXPECT_FALSE(second.compiled);
  EXPECT_EQ(first.cache_entry, second.cache_entry);

  // The loaded code computes what the checked-in generated code computes.
  std::mt19937 rng(9);
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::VectorXd q = test::random_vector(rng, 6, 3), qd = test::random_vector(rng, 6, 2);
    models::paper_reference::MassMatrix<double> M;
    models::paper_reference::Coordinates<double> bias;
    models::paper_reference::mass_matrix<double>(q, {}, M);
    models::paper_reference::bias_forces<double>(q, qd, {}, bias);
    EXPECT_MATRIX_NEAR(b.mass_matrix(q, Eigen::VectorXd()), M, 1e-14);
    EXPECT_MATRIX_NEAR(b.bias_forces(q, qd, Eigen::VectorXd()), bias, 1e-13);
  }
  EXPECT_THROW(b.mass_matrix(Eigen::VectorXd::Zero(5), Eigen::VectorXd()), std::invalid_argument);
  fs::remove_all(cache);
}

// Across processes, as in real use (within one process glibc keeps a loaded library mapped
// under its path, so a library cannot be replaced under a running process anyway).
TEST(CompiledModel, CorruptedEntryIsDetectedAndRebuilt) {
  const fs::path cache = fresh_cache("corrupt");
  const std::string cmd = std::string(SPACEARM_CLI) +
                          " eval --engine compiled --json --verbose --cache-dir " + cache.string() +
                          " " + SPACEARM_SOURCE_DIR +
                          "/models/paper_reference.yaml --q 0,0,0,0.1,0.2,0.3 2>&1";
  const std::string first = run(cmd);
  ASSERT_NE(first.find("(built)"), std::string::npos) << first;
  fs::path entry;
  for (const auto& e : fs::directory_iterator(cache))
    if (fs::exists(e.path() / "COMPLETE")) entry = e.path();
  ASSERT_FALSE(entry.empty());
  // A half-written library (as after a crash or a full disk): detected, rebuilt, and right.
  fs::resize_file(entry / "libmodel.so", fs::file_size(entry / "libmodel.so") / 3);
  int status = 0;
  const std::string second = run(cmd, &status);
  EXPECT_EQ(status, 0) << second;
  EXPECT_NE(second.find("is corrupted"), std::string::npos) << second;
  EXPECT_NE(second.find("(built)"), std::string::npos) << second;
  EXPECT_NE(second.find("\"mass_matrix\":"), std::string::npos) << second;
  // A missing COMPLETE marker (a build that never finished) also means: build again.
  fs::remove(entry / "COMPLETE");
  const std::string third = run(cmd);
  EXPECT_NE(third.find("(built)"), std::string::npos) << third;
  // And an intact entry is simply used.
  EXPECT_NE(run(cmd).find("(hit)"), std::string::npos);
  fs::remove_all(cache);
}

TEST(CompiledModel, ConcurrentBuildsOfOneModelDoNotCorruptTheCache) {
  const fs::path cache = fresh_cache("concurrent");
  const std::string cmd = std::string(SPACEARM_CLI) + " eval --json --cache-dir " + cache.string() +
                          " " + SPACEARM_SOURCE_DIR +
                          "/models/paper_reference.yaml --q 0,0,0,0.1,0.2,0.3";
  // Three processes start on an empty cache at once.
  const std::string out =
      run("(" + cmd + " > " + cache.string() + ".a & " + cmd + " > " + cache.string() + ".b & " +
          cmd + " > " + cache.string() + ".c & wait) 2>&1; cat " + cache.string() + ".a " +
          cache.string() + ".b " + cache.string() + ".c");
  size_t results = 0;
  for (size_t pos = 0; (pos = out.find("\"mass_matrix\":", pos)) != std::string::npos; ++pos)
    ++results;
  EXPECT_EQ(results, 3u) << out;
  // One valid entry, no leftovers of the private build folders.
  int entries = 0;
  for (const auto& e : fs::directory_iterator(cache)) {
    EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << e.path();
    if (fs::exists(e.path() / "COMPLETE")) ++entries;
  }
  EXPECT_EQ(entries, 1);
  for (const char* s : {".a", ".b", ".c"}) fs::remove(cache.string() + s);
  fs::remove_all(cache);
}

// A model file's text.
std::string model_text(const std::string& name) {
  std::ifstream in(std::string(SPACEARM_SOURCE_DIR) + "/models/" + name);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(CompiledModel, ChangedSceneIsRebuilt) {
  const fs::path cache = fresh_cache("rebuild");
  CompileOptions options;
  options.cache_dir = cache.string();
  const std::string text = model_text("paper_geared.yaml");
  const Scene original = parse_scene(text, "geared.yaml");
  std::string changed_text = text;
  changed_text.replace(changed_text.find("p: 1.0"), 6, "p: 2.0");
  const Scene changed = parse_scene(changed_text, "geared.yaml");
  StageReport r1, r2, r3;
  CompiledModel::load(original, options, &r1);
  CompiledModel::load(changed, options, &r2);
  CompiledModel::load(original, options, &r3);
  EXPECT_TRUE(r1.compiled);
  EXPECT_TRUE(r2.compiled);
  EXPECT_NE(r1.cache_entry, r2.cache_entry);
  EXPECT_FALSE(r3.compiled);  // both entries stay valid
  fs::remove_all(cache);
}

// The library describes its model (C interface 8): the facts read from it are the scene's, and
// mass_matrix_and_bias gives in one call what mass_matrix and bias_forces give apart.
TEST(CompiledModel, LibraryStatesTheModelsFacts) {
  const fs::path cache = fresh_cache("facts");
  CompileOptions options;
  options.cache_dir = cache.string();
  for (const char* file : {"/models/paper_flexible.yaml", "/tests/scenes/fixed_n4_geared.yaml"}) {
    const Scene scene = load_scene(std::string(SPACEARM_SOURCE_DIR) + file);
    const CompiledModel m = CompiledModel::load(scene, options);
    SCOPED_TRACE(file);
    EXPECT_EQ(m.name(), scene.name);
    EXPECT_EQ(m.free_floating(), scene.free_floating());
    EXPECT_EQ(m.num_base(), scene.free_floating() ? 3 : 0);
    EXPECT_EQ(m.passive_forces(), scene.num_flexible() > 0 || scene.has_friction());
    EXPECT_EQ(m.quaternion_offset(), -1);  // planar: nq = nv
    ASSERT_EQ(m.motor_angle_slots().size(), size_t(scene.num_links()));
    for (int j = 0; j < scene.num_links(); ++j)
      EXPECT_EQ(m.motor_angle_slots()[j], scene.has_gear(j) && !scene.is_flexible(j)) << j;
    const Eigen::VectorXd params = Eigen::Map<const Eigen::VectorXd>(m.nominal_parameters().data(),
                                                                     m.nominal_parameters().size());
    const Eigen::VectorXd q = Eigen::VectorXd::LinSpaced(m.nq(), 0.2, 1.1);
    const Eigen::VectorXd qd = Eigen::VectorXd::LinSpaced(m.nv(), -0.7, 0.4);
    Eigen::MatrixXd M;
    Eigen::VectorXd b;
    m.mass_matrix_and_bias(q, qd, params, M, b);
    EXPECT_TRUE(M.isApprox(m.mass_matrix(q, params), 1e-14));
    EXPECT_TRUE(b.isApprox(m.bias_forces(q, qd, params), 1e-14));
  }
  fs::remove_all(cache);
}

// Issue 49, item 10: the library lists the numbers whose span a failure names; at the nominal
// values (which the generator's self-check passed) nothing is said, and run-time parameters that
// widen the span name it by field and parameter. Cost: one compile of paper_geared, about 1 s.
TEST(CompiledModel, ParametersThatWidenTheSpanOfValuesAreNamed) {
  const fs::path cache = fresh_cache("span");
  CompileOptions options;
  options.cache_dir = cache.string();
  const Scene scene = load_scene(std::string(SPACEARM_SOURCE_DIR) + "/models/paper_geared.yaml");
  const CompiledModel m = CompiledModel::load(scene, options);
  Eigen::VectorXd params = Eigen::Map<const Eigen::VectorXd>(m.nominal_parameters().data(),
                                                             m.nominal_parameters().size());
  EXPECT_EQ(m.span_note(params), "");
  EXPECT_NE(m.value_span(params).find("from gears[0].motor_inertia (Im) = 1e-05 to base.mass"),
            std::string::npos)
      << m.value_span(params);
  params[0] = 1e-29;  // p
  EXPECT_NE(m.span_note(params).find("widen the model's span of values to 30 decades, from "
                                     "gears[0].ratio (p) = 1e-29 to base.mass = 64.86 (from 6 "
                                     "decades at the nominal values)"),
            std::string::npos)
      << m.span_note(params);
  fs::remove_all(cache);
}

// A spatial arm (space: spatial) loads through the same cache: the library states the free
// joint's layout, its functions give the spatial chain's values (its reference in double), a
// second load is a cache hit, and a base quaternion of norm 0 is refused by name while a
// non-unit one is normalized. Cost: one compile, about 1 s.
TEST(CompiledModel, LoadsASpatialArmThroughTheSameCache) {
  const fs::path cache = fresh_cache("spatial");
  CompileOptions options;
  options.cache_dir = cache.string();
  const std::string text = R"(name: arm2
space: spatial
base: {type: free_floating, mass: 50, com: [0.1, 0, 0], inertia: [10, 0.1, 0, 12, 0, 15]}
links:
  - {origin: [0.5, 0, 0.2], axis: [0, 0, 1], mass: 5, com: [0.2, 0, 0],
     inertia: [0.01, 0, 0, 0.2, 0, 0.2]}
  - {origin: [0.4, 0, 0], rpy: [1.5707963, 0, 0], axis: [0, 1, 0], mass: 3, com: [0.2, 0, 0],
     inertia: [0.01, 0.001, 0, 0.1, 0, 0.1]}
gears: {ratio: 50, rotor_inertia: [1.0e-4, 6.0e-5], rotor_coupling: exact}
outputs: [mass_matrix, bias_forces, kinetic_energy, momentum, forward_dynamics,
          forward_dynamics_derivatives, end_effector_pose, end_effector_jacobian]
)";
  const ModelRecipe recipe = ModelRecipe::parse(text, "arm2.yaml");
  StageReport first, second;
  const CompiledModel m = CompiledModel::load(recipe, options, &first);
  CompiledModel::load(recipe, options, &second);
  EXPECT_TRUE(first.compiled);
  EXPECT_FALSE(second.generated || second.compiled);
  EXPECT_EQ(m.nq(), 9);
  EXPECT_EQ(m.nv(), 8);
  EXPECT_EQ(m.num_base(), 6);
  EXPECT_EQ(m.quaternion_offset(), 3);
  EXPECT_TRUE(m.dimensions().spatial);
  EXPECT_EQ(m.coordinate_names()[3], "qw0");

  const SpatialScene scene = parse_spatial_scene(text, "arm2.yaml");
  const DerivedModel derived = spatial_derived_model(scene);  // refers to scene
  Eigen::VectorXd q(9), qd(8), qdd(8);
  q << 0.1, -0.2, 0.3, 0.5, 0.5, -0.5, 0.5, 0.7, -1.1;
  qd << 0.2, 0.1, -0.3, 0.4, -0.2, 0.3, 5.0, -8.0;
  qdd << 0.3, -0.1, 0.2, 0.1, 0.2, -0.3, 1.0, 2.0;
  const Eigen::VectorXd params(0);
  for (Output o : recipe.facts().outputs) {
    SCOPED_TRACE(info(o).name);
    std::vector<Eigen::VectorXd> inputs;
    for (Input in : info(o).inputs)
      inputs.push_back(in == Input::q ? q : in == Input::qd ? qd : qdd);
    const auto got = m.evaluate(o, inputs, params);
    const auto want = derived.reference(o, inputs, params);
    ASSERT_EQ(got.size(), want.size());
    for (size_t r = 0; r < got.size(); ++r)
      EXPECT_LT((got[r] - want[r]).norm(), 1e-12 * (1 + want[r].norm())) << r;
  }
  // A non-unit quaternion is the same rotation; a zero one is an error naming it.
  Eigen::VectorXd scaled = q;
  scaled.segment(3, 4) *= 3;
  EXPECT_LT((m.mass_matrix(scaled, params) - m.mass_matrix(q, params)).norm(), 1e-12);
  Eigen::VectorXd zero = q;
  zero.segment(3, 4).setZero();
  EXPECT_THROW_MESSAGE(m.mass_matrix(zero, params), std::invalid_argument,
                       "q[3..6], the base's orientation quaternion (w, x, y, z), has norm 0");

  // Free motion through the runtime's integrators: the quaternion stays unit (projected after
  // each step), momentum and energy are conserved (rosenbrock4 with its Jacobian of
  // dq/dt = f(q, v), configuration_space.hpp, and rkf78).
  const DynamicModel dm = dynamic_model(m, params);
  const Eigen::VectorXd h0 = dm.momentum(q, qd);
  const double T0 = dm.kinetic_energy(q, qd);
  for (Method method : {Method::rkf78, Method::rosenbrock4}) {
    SCOPED_TRACE(to_string(method));
    IntegratorOptions opt;
    opt.method = method;
    opt.rtol = opt.atol = method == Method::rkf78 ? 1e-11 : 1e-9;
    double worst_norm = 0, worst_h = 0, worst_T = 0;
    integrate_motion(
        dm, q, qd, [](double) { return Eigen::VectorXd::Zero(2); }, 2.0, 0.1, opt,
        [&](double, const Eigen::VectorXd& qt, const Eigen::VectorXd& vt) {
          worst_norm = std::max(worst_norm, std::abs(qt.segment(3, 4).norm() - 1));
          worst_h = std::max(worst_h, (dm.momentum(qt, vt) - h0).norm() / h0.norm());
          worst_T = std::max(worst_T, std::abs(dm.kinetic_energy(qt, vt) - T0) / T0);
        });
    EXPECT_LT(worst_norm, 1e-14);
    EXPECT_LT(worst_h, method == Method::rkf78 ? 1e-9 : 1e-6);
    EXPECT_LT(worst_T, method == Method::rkf78 ? 1e-9 : 1e-6);
  }
  fs::remove_all(cache);
}

// Joint friction in 3D through the cache: the library's friction, forward and inverse dynamics
// are the chain's in double, and the runtime's model sees the passive forces.
TEST(CompiledModel, ASpatialArmWithFrictionGivesTheChainsValues) {
  const fs::path cache = fresh_cache("spatial-friction");
  CompileOptions options;
  options.cache_dir = cache.string();
  std::string text =
      test::read_text_file(std::string(SPACEARM_SOURCE_DIR) + "/tests/scenes/spatial_arm2.yaml");
  text +=
      "friction: [{viscous: 0.002, coulomb: 0.05, velocity_scale: 0.1, stribeck_static: 0.08, "
      "stribeck_velocity: 0.5}, {viscous: 0.001}]\n";
  const ModelRecipe recipe = ModelRecipe::parse(text, "spatial_arm2.yaml");
  const CompiledModel m = CompiledModel::load(recipe, options);
  ASSERT_TRUE(m.has(Output::friction_forces));
  const SpatialScene scene = parse_spatial_scene(text, "spatial_arm2.yaml");
  const DerivedModel derived = spatial_derived_model(scene);  // refers to scene
  Eigen::VectorXd q(9), qd(8), qdd(8);
  q << 0.1, -0.2, 0.3, 0.5, 0.5, -0.5, 0.5, 0.7, -1.1;
  qd << 0.2, 0.1, -0.3, 0.4, -0.2, 0.3, 0.4, -8.0;
  qdd << 0.3, -0.1, 0.2, 0.1, 0.2, -0.3, 1.0, 2.0;
  for (Output o : {Output::friction_forces, Output::forward_dynamics, Output::inverse_dynamics}) {
    SCOPED_TRACE(info(o).name);
    std::vector<Eigen::VectorXd> inputs;
    for (Input in : info(o).inputs)
      inputs.push_back(in == Input::q ? q : in == Input::qd ? qd : qdd);
    const auto got = m.evaluate(o, inputs, Eigen::VectorXd());
    const auto want = derived.reference(o, inputs, Eigen::VectorXd());
    for (size_t r = 0; r < got.size(); ++r)
      EXPECT_LT((got[r] - want[r]).norm(), 1e-12 * (1 + want[r].norm())) << r;
  }
  const DynamicModel dm = dynamic_model(m, Eigen::VectorXd());
  EXPECT_TRUE(dm.passive_forces);
  const Eigen::VectorXd f = dm.friction_forces(qd);
  EXPECT_GT(f[6] * qd[6], 0);
  EXPECT_GT(f[7] * qd[7], 0);
  fs::remove_all(cache);
}

// The cache builds for the host's widest vector instruction set: with -ffp-contract=off its
// results are SSE2's to the last bit, in every output a spatial arm gives (with contraction into
// FMA, 42 entries of the default outputs differ).
TEST(CompiledModel, TheHostInstructionSetGivesTheBitsOfSse2) {
  if (host_instruction_set() == "sse2") GTEST_SKIP() << "this CPU has neither AVX2 nor AVX-512";
  const fs::path cache = fresh_cache("isa");
  std::string text =
      test::read_text_file(std::string(SPACEARM_SOURCE_DIR) + "/tests/scenes/spatial_arm2.yaml");
  text +=
      "outputs: [mass_matrix, coriolis_matrix, mass_matrix_derivative, bias_forces, "
      "kinetic_energy, momentum, inverse_dynamics, forward_dynamics, "
      "forward_dynamics_derivatives, end_effector_pose, end_effector_jacobian, "
      "generalized_jacobian, free_base_inverse_dynamics]\n";
  const ModelRecipe recipe = ModelRecipe::parse(text, "spatial_arm2.yaml");
  CompileOptions host, sse2;
  host.cache_dir = sse2.cache_dir = cache.string();
  sse2.instruction_set = "sse2";
  const CompiledModel a = CompiledModel::load(recipe, host), b = CompiledModel::load(recipe, sse2);
  Eigen::VectorXd q(9), qd(8), qdd(8);
  q << 0.1, -0.2, 0.3, 0.5, 0.5, -0.5, 0.5, 0.7, -1.1;
  qd << 0.2, 0.1, -0.3, 0.4, -0.2, 0.3, 5.0, -8.0;
  qdd << 0.3, -0.1, 0.2, 0.1, 0.2, -0.3, 1.0, 2.0;
  ASSERT_EQ(recipe.facts().outputs.size(), 13u);
  for (Output o : recipe.facts().outputs) {
    std::vector<Eigen::VectorXd> inputs;
    for (Input in : info(o).inputs)
      inputs.push_back(in == Input::q                     ? q
                       : in == Input::qd                  ? qd
                       : in == Input::joint_accelerations ? Eigen::VectorXd(qdd.tail(2))
                                                          : qdd);
    const auto x = a.evaluate(o, inputs, Eigen::VectorXd()),
               y = b.evaluate(o, inputs, Eigen::VectorXd());
    ASSERT_EQ(x.size(), y.size());
    for (size_t r = 0; r < x.size(); ++r)
      for (Eigen::Index i = 0; i < x[r].size(); ++i)
        EXPECT_EQ(x[r].data()[i], y[r].data()[i])
            << info(o).name << " result " << r << " entry " << i;
  }
  fs::remove_all(cache);
}

// The 4-lane functions (spacearm_<name>_x4) compute, in each lane, what the scalar function
// computes for that lane's state and parameters, bit for bit: four different states and
// parameter sets at once, through libmvec's sin and cos (the build's vector trig), friction's
// tanh and exp, springs, and a base floating in 3D; built for this CPU and for SSE2 (where the
// four lanes are two halves). Only the outputs of has_lanes_version have them, and those a scene
// lists under `lanes:` (the spatial arm's state Jacobian).
TEST(CompiledModel, FourLanesComputeWhatTheScalarFunctionComputes) {
  const fs::path cache = fresh_cache("lanes");
  const std::string spatial =
      test::read_text_file(std::string(SPACEARM_SOURCE_DIR) + "/tests/scenes/spatial_arm2.yaml") +
      "outputs: [mass_matrix, forward_dynamics, end_effector_pose, momentum, kinetic_energy, "
      "forward_dynamics_derivatives]\nlanes: [forward_dynamics_derivatives]\n";
  const std::vector<ModelRecipe> recipes = {
      ModelRecipe::load(std::string(SPACEARM_SOURCE_DIR) + "/models/paper_flexible.yaml"),
      ModelRecipe::parse(spatial, "spatial_arm2.yaml")};
  ASSERT_EQ(recipes[1].facts().lanes, std::vector<Output>{Output::forward_dynamics_derivatives});
  for (const std::string& isa : {host_instruction_set(), std::string("sse2")})
    for (const ModelRecipe& recipe : recipes) {
      SCOPED_TRACE(recipe.name() + " built for " + isa);
      CompileOptions options;
      options.cache_dir = cache.string();
      options.instruction_set = isa;
      const CompiledModel m = CompiledModel::load(recipe, options);
      ASSERT_NE(m.lanes_function(Output::forward_dynamics), nullptr);
      EXPECT_EQ(m.has(Output::mass_matrix) ? m.lanes_function(Output::mass_matrix) : nullptr,
                nullptr);
      const std::vector<Output>& asked = recipe.facts().lanes;  // the scene's `lanes:`
      EXPECT_EQ(m.lanes_function(Output::forward_dynamics_derivatives) != nullptr,
                std::count(asked.begin(), asked.end(), Output::forward_dynamics_derivatives) == 1);
      const Dimensions& d = m.dimensions();
      const size_t np = m.nominal_parameters().size();
      for (Output o : recipe.facts().outputs) {
        if (!m.lanes_function(o)) continue;
        // Lane l: inputs 0.3 + 0.1 i + 0.07 l (a unit quaternion in q), parameters p (1 + l / 8).
        std::vector<std::vector<double>> in, in4, out4;
        for (Input i : info(o).inputs) {
          in4.emplace_back(4 * d(info(i).size));
          for (size_t k = 0; k < in4.back().size(); ++k)
            in4.back()[k] = 0.3 + 0.1 * static_cast<double>(k / 4) + 0.07 * (k % 4);
          if (i == Input::q && m.quaternion_offset() >= 0)
            for (int l = 0; l < 4; ++l) {
              const int k = m.quaternion_offset();
              const Eigen::Vector4d quat = Eigen::Vector4d(1, 0.2 * l, -0.1, 0.3).normalized();
              for (int j = 0; j < 4; ++j) in4.back()[4 * (k + j) + l] = quat[j];
            }
        }
        std::vector<double> params4;
        for (double p : m.nominal_parameters())
          for (int l = 0; l < 4; ++l) params4.push_back(p * (1 + l / 8.0));
        for (const ResultInfo& r : info(o).results)
          out4.emplace_back(4 * d(r.rows) * d(r.cols), -1.0);
        std::vector<const double*> in_ptr;
        std::vector<double*> out_ptr;
        for (const auto& v : in4) in_ptr.push_back(v.data());
        for (auto& v : out4) out_ptr.push_back(v.data());
        m.lanes_function(o)(in_ptr.data(), params4.data(), out_ptr.data());
        for (int l = 0; l < 4; ++l) {
          std::vector<std::vector<double>> lane_in, lane_out;
          for (const auto& v : in4) {
            lane_in.emplace_back();
            for (size_t k = l; k < v.size(); k += 4) lane_in.back().push_back(v[k]);
          }
          std::vector<double> lane_params;
          for (size_t j = 0; j < np; ++j) lane_params.push_back(params4[4 * j + l]);
          for (const auto& v : out4) lane_out.emplace_back(v.size() / 4);
          in_ptr.clear(), out_ptr.clear();
          for (const auto& v : lane_in) in_ptr.push_back(v.data());
          for (auto& v : lane_out) out_ptr.push_back(v.data());
          m.function(o)(in_ptr.data(), lane_params.data(), out_ptr.data());
          for (size_t r = 0; r < lane_out.size(); ++r)
            for (size_t i = 0; i < lane_out[r].size(); ++i) {
              ASSERT_TRUE(std::isfinite(lane_out[r][i])) << info(o).name;
              EXPECT_EQ(std::memcmp(&lane_out[r][i], &out4[r][4 * i + l], sizeof(double)), 0)
                  << info(o).name << " result " << r << " entry " << i << " lane " << l << ": "
                  << lane_out[r][i] << " vs " << out4[r][4 * i + l];
            }
        }
      }
    }
  fs::remove_all(cache);
}

// evaluate_batch with null results (forward_dynamics' pivots, which the Python binding does not
// return): qdd is the same bits as with every result kept, on one lane and four. Whatever fails
// first names its state, inputs or results, across the scalar path's runs of 16 states (its
// inputs tested a run at a time, a state's results after the next state is evaluated).
TEST(CompiledModel, BatchesNameTheFirstFailingStateAndResultsNotKeptAreStillChecked) {
  const fs::path cache = fresh_cache("batch_null");
  CompileOptions options;
  options.cache_dir = cache.string();
  const CompiledModel m = CompiledModel::load(
      ModelRecipe::load(std::string(SPACEARM_SOURCE_DIR) + "/models/paper_geared.yaml"), options);
  const int n = m.dimensions().nv;
  const long k = 37;  // nine groups of four and one state alone; two runs of 16 and five
  std::vector<double> q(k * n), qd(k * n), Q(k * n);
  for (size_t i = 0; i < q.size(); ++i) {
    q[i] = std::sin(0.7 * i), qd[i] = std::cos(1.3 * i), Q[i] = 5 * std::sin(2.1 * i + 1);
  }
  const auto& nominal = m.nominal_parameters();
  const Eigen::VectorXd params = Eigen::Map<const Eigen::VectorXd>(nominal.data(), nominal.size());
  // The message of the error of a batch where q and Q are changed by `edit`, qdd alone kept.
  auto error = [&](int lanes,
                   const std::function<void(std::vector<double>&, std::vector<double>&)>& edit)
      -> std::string {
    std::vector<double> q1 = q, Q1 = Q, qdd(k * n);
    edit(q1, Q1);
    try {
      m.evaluate_batch(Output::forward_dynamics, k, {q1.data(), qd.data(), Q1.data()}, params,
                       {qdd.data(), nullptr, nullptr}, lanes);
    } catch (const std::exception& e) {
      return e.what();
    }
    return "no error";
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int lanes : {4, 1}) {
    SCOPED_TRACE("lanes = " + std::to_string(lanes));
    std::vector<double> qdd(k * n), pivots(k * n), scaled(k * n), qdd_alone(k * n, -1.0);
    m.evaluate_batch(Output::forward_dynamics, k, {q.data(), qd.data(), Q.data()}, params,
                     {qdd.data(), pivots.data(), scaled.data()}, lanes);
    m.evaluate_batch(Output::forward_dynamics, k, {q.data(), qd.data(), Q.data()}, params,
                     {qdd_alone.data(), nullptr, nullptr}, lanes);
    EXPECT_EQ(std::memcmp(qdd.data(), qdd_alone.data(), qdd.size() * sizeof(double)), 0);
    // One pivot array kept, the other not (the scaled ones go to the room of results not kept).
    std::vector<double> qdd2(k * n), pivots2(k * n);
    m.evaluate_batch(Output::forward_dynamics, k, {q.data(), qd.data(), Q.data()}, params,
                     {qdd2.data(), pivots2.data(), nullptr}, lanes);
    EXPECT_EQ(qdd2, qdd);
    EXPECT_EQ(pivots2, pivots);
    // A matrix result not kept (transposed into that room), and a state named all the same.
    std::vector<double> bad_q = q;
    bad_q[3 * n + 1] = std::numeric_limits<double>::infinity();
    m.evaluate_batch(Output::mass_matrix, k, {q.data()}, params, {nullptr}, lanes);
    try {
      m.evaluate_batch(Output::mass_matrix, k, {bad_q.data()}, params, {nullptr}, lanes);
      ADD_FAILURE() << "no error";
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()).rfind("state 3: q[1] is not finite", 0), 0u) << e.what();
    }
    // Accelerations overflow in state 6 (torques of 1e308); q not finite in state 20.
    auto overflow = [n](std::vector<double>& Q1, long s) {
      for (int i = 0; i < n; ++i) Q1[s * n + i] = 1e308;
    };
    std::string what = error(lanes, [&](auto&, auto& Q1) { overflow(Q1, 6); });
    EXPECT_EQ(what.rfind("state 6: ", 0), 0u) << what;
    EXPECT_NE(what.find("accelerations not finite"), std::string::npos) << what;
    what = error(lanes, [&](auto& q1, auto&) { q1[20 * n + 2] = nan; });
    EXPECT_EQ(what.rfind("state 20: q[2] is not finite", 0), 0u) << what;
    // Results failing in state 5 come before inputs failing in state 6, and the other way round.
    what = error(lanes, [&](auto& q1, auto& Q1) { overflow(Q1, 5), q1[6 * n] = nan; });
    EXPECT_EQ(what.rfind("state 5: ", 0), 0u) << what;
    what = error(lanes, [&](auto& q1, auto& Q1) { q1[5 * n] = nan, overflow(Q1, 6); });
    EXPECT_EQ(what.rfind("state 5: q[0] is not finite", 0), 0u) << what;
    what = error(lanes, [&](auto& q1, auto& Q1) { overflow(Q1, 15), q1[16 * n] = nan; });
    EXPECT_EQ(what.rfind("state 15: ", 0), 0u) << what;
    EXPECT_NE(what.find("accelerations not finite"), std::string::npos) << what;
  }
  fs::remove_all(cache);
}

// An entry built for another instruction set this CPU runs stands in where none can be built
// (no compiler, a folder that cannot be written); one for a set it does not run is named, never
// loaded.
TEST(CompiledModel, AnEntryOfAnotherInstructionSetLoadsWhereNoneCanBeBuilt) {
  const fs::path cache = fresh_cache("other-set");
  const ModelRecipe recipe =
      ModelRecipe::load(std::string(SPACEARM_SOURCE_DIR) + "/tests/scenes/spatial_arm2.yaml");
  CompileOptions sse2;
  sse2.cache_dir = cache.string();
  sse2.instruction_set = "sse2";
  StageReport built;
  CompiledModel::load(recipe, sse2, &built);
  EXPECT_NE(built.cache_entry.find("-sse2-"), std::string::npos) << built.cache_entry;
  CompileOptions none;
  none.cache_dir = cache.string();
  none.compiler = "/nonexistent/c++";
  StageReport loaded;
  const CompiledModel m = CompiledModel::load(recipe, none, &loaded);
  EXPECT_EQ(loaded.cache_entry, built.cache_entry);
  EXPECT_EQ(m.nv(), 8);
  // The same entry marked for a set no CPU runs.
  const std::string renamed = built.cache_entry.substr(0, built.cache_entry.find("-sse2-")) +
                              "-future-" +
                              built.cache_entry.substr(built.cache_entry.find("-sse2-") + 6);
  fs::rename(built.cache_entry, renamed);
  EXPECT_THROW_MESSAGE(CompiledModel::load(recipe, none), CompileError,
                       "' is built for 'future', which this CPU does not run");
  sse2.instruction_set = "avx9";
  EXPECT_THROW_MESSAGE(CompiledModel::load(recipe, sse2), CompileError,
                       "instruction set 'avx9' is not one of avx512f, avx2, sse2");
  fs::remove_all(cache);
}

// Two models loaded at once are two libraries: dlopen matches the name it is given
// (/proc/self/fd/N), so a second model opened under the first one's number would silently be
// the first one.
TEST(CompiledModel, ModelsLoadedAtOnceAreTheirOwn) {
  const fs::path cache = fresh_cache("two-at-once");
  CompileOptions options;
  options.cache_dir = cache.string();
  const std::string text = model_text("paper_reference.yaml");
  std::string heavier = text;
  heavier.replace(heavier.find("mass: 64.859"), 12, "mass: 100.0");
  const CompiledModel a = CompiledModel::load(parse_scene(text, "a.yaml"), options);
  const CompiledModel b = CompiledModel::load(parse_scene(heavier, "b.yaml"), options);
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(6);
  const Eigen::VectorXd params(0);
  // M(0, 0) is the total mass.
  EXPECT_NEAR(b.mass_matrix(q, params)(0, 0) - a.mass_matrix(q, params)(0, 0), 100.0 - 64.859,
              1e-12);
  fs::remove_all(cache);
}

// The loaded model at dynamic size (dynamic_model) gives the linked model's values at the same
// parameters and the same DynamicsError for a NaN; it has only what the scene emits.
TEST(CompiledModel, DynamicModelOfLoadedCodeEqualsTheLinkedModel) {
  const fs::path dir = fresh_cache("dynamic");
  CompileOptions options;
  options.cache_dir = dir.string();
  const Scene scene = load_scene(std::string(SPACEARM_SOURCE_DIR) + "/models/paper_geared.yaml");
  const CompiledModel loaded = CompiledModel::load(scene, options);
  Eigen::VectorXd params = Eigen::Map<const Eigen::VectorXd>(loaded.nominal_parameters().data(),
                                                             loaded.nominal_parameters().size());
  params[0] = 10;  // p
  const DynamicModel d = dynamic_model(loaded, params);
  using G = models::paper_geared::Model;
  Model<G> linked;
  linked.set_parameter("p", 10);
  EXPECT_EQ(d.coordinate_names,
            std::vector<std::string>(G::coordinate_names().begin(), G::coordinate_names().end()));
  EXPECT_TRUE(d.free_floating);
  EXPECT_MATRIX_NEAR(d.gear_ratios, Eigen::VectorXd(linked.gear_ratios()), 0);
  Model<G>::Vector q;
  q << 0.1, -0.2, 0.3, 3.0, 12.0, -5.0;
  Model<G>::Velocity qd;
  qd << 0.05, 0.02, -0.1, 2.0, -3.0, 4.0;
  const Eigen::VectorXd Q = d.generalized_forces(Eigen::Vector3d(0.1, -0.2, 0.3));
  EXPECT_MATRIX_NEAR(d.forward_dynamics(q, qd, Q), linked.forward_dynamics(q, qd, Q), 1e-13);
  EXPECT_MATRIX_NEAR(d.momentum(q, qd), linked.momentum(q, qd), 1e-13);
  EXPECT_NEAR(d.kinetic_energy(q, qd), linked.kinetic_energy(q, qd), 1e-13);
  EXPECT_MATRIX_NEAR(d.end_effector_jacobian(q), linked.end_effector_jacobian(q), 1e-13);
  Eigen::VectorXd bad = q;
  bad[3] = std::nan("");
  EXPECT_THROW_MESSAGE(d.forward_dynamics(bad, qd, Q), DynamicsError,
                       "model paper_geared: non-finite input q[3] (qm1) = nan");
  EXPECT_THROW_MESSAGE(d.forward_dynamics(q.head(5), qd, Q), std::invalid_argument,
                       "q: expected 6 values, got 5");
  params[0] = -1;
  EXPECT_THROW(dynamic_model(loaded, params), std::invalid_argument);
  fs::remove_all(dir);
}

// One adapter (dynamic_model_of) behind both: a loaded and a linked model state the same facts
// and layout and have the same functions, for a rigid gear (each slot holds qm) and a flexible
// joint (each slot holds q, its motor angle a coordinate after the joints).
template <class G>
void expect_same_adapter(const std::string& scene_file, const CompileOptions& options) {
  SCOPED_TRACE(scene_file);
  const Scene scene = load_scene(std::string(SPACEARM_SOURCE_DIR) + scene_file);
  const CompiledModel loaded = CompiledModel::load(scene, options);
  const Eigen::VectorXd params = Eigen::Map<const Eigen::VectorXd>(
      loaded.nominal_parameters().data(), loaded.nominal_parameters().size());
  const Model<G> linked;
  const DynamicModel a = dynamic_model(loaded, params), b = dynamic_model(linked);
  EXPECT_EQ(a.name, b.name);
  EXPECT_EQ(a.actuated_coordinates, b.actuated_coordinates);
  EXPECT_EQ(a.motor_angle_slots, b.motor_angle_slots);
  EXPECT_EQ(a.passive_forces, b.passive_forces);
  EXPECT_EQ(a.num_base(), b.num_base());
  EXPECT_EQ(a.joint_q_offsets, b.joint_q_offsets);
  EXPECT_EQ(a.joint_v_offsets, b.joint_v_offsets);
  EXPECT_EQ(a.quaternion_offset, b.quaternion_offset);
  EXPECT_EQ(a.gear_ratios, b.gear_ratios);
  EXPECT_EQ(bool(a.forward_dynamics), bool(b.forward_dynamics));
  EXPECT_EQ(bool(a.mass_matrix_and_bias), bool(b.mass_matrix_and_bias));
  EXPECT_EQ(bool(a.end_effector_pose), bool(b.end_effector_pose));
  EXPECT_EQ(bool(a.end_effector_jacobian), bool(b.end_effector_jacobian));
  EXPECT_EQ(bool(a.kinetic_energy), bool(b.kinetic_energy));
  EXPECT_EQ(bool(a.potential_energy), bool(b.potential_energy));
  EXPECT_EQ(bool(a.friction_forces), bool(b.friction_forces));
  EXPECT_EQ(bool(a.forward_dynamics_derivatives), bool(b.forward_dynamics_derivatives));
  EXPECT_EQ(bool(a.momentum), bool(b.momentum));
  for (int j = 0; j < scene.num_links(); ++j)
    EXPECT_EQ(b.slot_holds_motor(j), scene.has_gear(j) && !scene.is_flexible(j)) << j;
}

TEST(CompiledModel, LoadedAndLinkedModelsShareOneAdapter) {
  const fs::path dir = fresh_cache("adapter");
  CompileOptions options;
  options.cache_dir = dir.string();
  expect_same_adapter<models::paper_geared::Model>("/models/paper_geared.yaml", options);
  expect_same_adapter<models::paper_flexible::Model>("/models/paper_flexible.yaml", options);
  fs::remove_all(dir);
}

TEST(CompiledModel, CompileFailureReportsTheCompilerMessage) {
  const fs::path cache = fresh_cache("fail");
  CompileOptions options;
  options.cache_dir = cache.string();
  options.flags = "-O2 -std=c++17 -fPIC -shared -include spacearm_missing_header.h";
  const Scene scene = load_scene(SPACEARM_SOURCE_DIR "/models/paper_reference.yaml");
  try {
    CompiledModel::load(scene, options);
    FAIL() << "compiled with a broken flag";
  } catch (const CompileError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("error"), std::string::npos) << what;
    EXPECT_NE(what.find("sources and command: " + (cache / "failed").string()), std::string::npos)
        << what;
  }
  // The cache holds no valid entry for it: the next good build compiles.
  options.flags = CompileOptions().flags;
  StageReport r;
  CompiledModel::load(scene, options, &r);
  EXPECT_TRUE(r.compiled);
  fs::remove_all(cache);
}

}  // namespace
}  // namespace spacearm
