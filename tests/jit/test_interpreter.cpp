// jit/interpreter.hpp: the interpreted code computes the compiled library's numbers bit for bit
// (every kept scene, every function, random states, scalar and four lanes), checks the
// parameters as the library does, and serves a model at once while the library is compiled in
// the background (Engine::automatic), which then takes over at a call boundary (the functions
// the caller calls first before the rest) and lands in the cache even when the model is dropped
// before it finishes.
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <thread>

#include "compiled_model.hpp"
#include "cli_fixtures.hpp"
#include "support.hpp"

namespace spacearm {
namespace {

namespace fs = std::filesystem;
using test::fresh_cache;

// The scenes kept in the repository, and a test scene with every friction form (tanh, exp).
std::vector<std::string> kept_scenes() {
  std::vector<std::string> paths;
  for (const char* name :
       {"paper_reference", "paper_geared", "paper_geared_armature", "paper_flexible", "space_arm7",
        "space_arm7_payload", "identified_arm3", "published/ets_vii"})
    paths.push_back(std::string(SPACEARM_SOURCE_DIR) + "/models/" + name + ".yaml");
  paths.push_back(std::string(SPACEARM_SOURCE_DIR) + "/tests/scenes/free_n4_mixed.yaml");
  return paths;
}

// Random inputs of a function (one state each, or four interleaved), q with a unit quaternion
// where the model has one, and parameters around the nominal ones.
struct Arguments {
  std::vector<std::vector<double>> in;
  std::vector<double> params;
  std::vector<std::vector<double>> out;
  std::vector<const double*> in_ptr;
  std::vector<double*> out_ptr;
  void point() {
    in_ptr.clear(), out_ptr.clear();
    for (const auto& v : in) in_ptr.push_back(v.data());
    for (auto& v : out) out_ptr.push_back(v.data());
  }
};

Arguments random_arguments(const CompiledModel& m, const InterpretedFunction& f, int lanes,
                           std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-2.5, 2.5), scale(0.8, 1.25);
  Arguments a;
  for (size_t k = 0; k < f.input_sizes.size(); ++k) {
    a.in.emplace_back(lanes * f.input_sizes[k]);
    for (double& x : a.in.back()) x = u(rng);
  }
  // Input 0 of a function that takes q is q (outputs.hpp's order).
  const int qk = m.quaternion_offset();
  if (qk >= 0 && !a.in.empty() && f.input_sizes[0] == m.nq())
    for (int l = 0; l < lanes; ++l) {
      double norm = 0;
      for (int j = 0; j < 4; ++j) norm += std::pow(a.in[0][lanes * (qk + j) + l], 2);
      for (int j = 0; j < 4; ++j) a.in[0][lanes * (qk + j) + l] /= std::sqrt(norm);
    }
  for (double p : m.nominal_parameters())
    for (int l = 0; l < lanes; ++l) a.params.push_back(p * scale(rng));
  for (int size : f.result_sizes) a.out.emplace_back(lanes * size, -7.0);
  a.point();
  return a;
}

// The interpreter's code of a scene, as the cache's load emits it.
InterpretedModel interpreted_code_of(const ModelRecipe& recipe) {
  EmitOptions eo;
  eo.interpreted = true;
  return *recipe.emit(eo).interpreted;
}

Output output_named(const std::string& name) {
  for (const auto& o : output_registry())
    if (name == o.name) return o.id;
  throw std::invalid_argument("no output " + name);
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// Every function of every kept scene, at 12 random states and 4 random 4-lane states: the
// interpreter's results are the compiled library's, bit for bit (about 40 s: the scenes compile).
TEST(Interpreter, ComputesTheCompiledNumbersBitForBitOnEveryKeptScene) {
  const fs::path cache = fresh_cache("interpreter_bits");
  std::mt19937 rng(20261128);
  for (const std::string& path : kept_scenes()) {
    const ModelRecipe recipe = ModelRecipe::load(path);
    SCOPED_TRACE(path);
    CompileOptions compiled, interpreted;
    compiled.cache_dir = cache.string();
    interpreted.engine = Engine::interpreter;
    StageReport rep;
    const CompiledModel c = CompiledModel::load(recipe, compiled);
    const CompiledModel i = CompiledModel::load(recipe, interpreted, &rep);
    ASSERT_TRUE(rep.interpreted);
    EXPECT_STREQ(i.engine(), "interpreter");
    EXPECT_STREQ(c.engine(), "compiled");
    const InterpretedModel code = interpreted_code_of(recipe);
    for (const InterpretedFunction& f : code.functions) {
      for (int lanes : {1, 4}) {
        if (lanes == 4 && !f.lanes) continue;
        const auto call = [&](const CompiledModel& m, Arguments& a) {
          if (lanes == 1)
            m.function(f.name)(a.in_ptr.data(), a.params.data(), a.out_ptr.data());
          else
            m.lanes_function(output_named(f.name))(a.in_ptr.data(), a.params.data(),
                                                   a.out_ptr.data());
        };
        for (int trial = 0; trial < (lanes == 1 ? 12 : 4); ++trial) {
          Arguments a = random_arguments(c, f, lanes, rng), b = a;
          b.point();
          call(c, a);
          call(i, b);
          for (size_t r = 0; r < a.out.size(); ++r)
            for (size_t e = 0; e < a.out[r].size(); ++e)
              ASSERT_TRUE(same_bits(a.out[r][e], b.out[r][e]))
                  << f.name << (lanes == 4 ? " (4 lanes)" : "") << " result " << r << " entry " << e
                  << ": compiled " << a.out[r][e] << ", interpreted " << b.out[r][e];
        }
      }
    }
  }
  fs::remove_all(cache);
}

// The checked calls: the same parameter errors (the scene's range checks, not-finite values) and
// the same dynamics, through evaluate().
TEST(Interpreter, ChecksParametersAsTheLibraryDoes) {
  const fs::path cache = fresh_cache("interpreter_checks");
  const ModelRecipe recipe =
      ModelRecipe::load(std::string(SPACEARM_SOURCE_DIR) + "/models/paper_flexible.yaml");
  CompileOptions compiled, interpreted;
  compiled.cache_dir = cache.string();
  interpreted.engine = Engine::interpreter;
  const CompiledModel c = CompiledModel::load(recipe, compiled);
  const CompiledModel i = CompiledModel::load(recipe, interpreted);
  const Eigen::VectorXd nominal = Eigen::Map<const Eigen::VectorXd>(
      c.nominal_parameters().data(), static_cast<Eigen::Index>(c.nominal_parameters().size()));
  const auto error = [&](const CompiledModel& m, const Eigen::VectorXd& p) {
    try {
      m.check_parameters(p);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  int refused = 0;
  for (Eigen::Index k = 0; k < nominal.size(); ++k)
    for (double factor : {-1.0, 0.0, 1e-30, 2.0}) {
      Eigen::VectorXd p = nominal;
      p[k] *= factor;
      const std::string e = error(c, p);
      refused += !e.empty();
      EXPECT_EQ(error(i, p), e) << c.parameter_names()[k] << " times " << factor;
    }
  EXPECT_GT(refused, 3);  // the rules were exercised
  const Eigen::VectorXd q = Eigen::VectorXd::LinSpaced(c.nq(), 0.1, 0.9),
                        qd = Eigen::VectorXd::LinSpaced(c.nv(), -0.3, 0.4),
                        tau = Eigen::VectorXd::Constant(c.nv(), 0.01);
  const Eigen::VectorXd a = c.forward_dynamics(q, qd, tau, nominal),
                        b = i.forward_dynamics(q, qd, tau, nominal);
  for (Eigen::Index k = 0; k < a.size(); ++k) EXPECT_TRUE(same_bits(a[k], b[k])) << k;
  fs::remove_all(cache);
}

// Engine::automatic on an empty cache: the interpreter answers at once; the library compiled in
// the background takes over (a held function switches at its next call, with the same numbers)
// and is in the cache for the next load, which neither generates nor compiles.
TEST(Interpreter, AutomaticServesAtOnceThenSwapsInTheCompiledLibrary) {
  const fs::path cache = fresh_cache("interpreter_auto");
  const ModelRecipe recipe =
      ModelRecipe::load(std::string(SPACEARM_SOURCE_DIR) + "/models/paper_geared.yaml");
  CompileOptions options;
  options.cache_dir = cache.string();
  options.engine = Engine::automatic;
  StageReport first;
  const CompiledModel m = CompiledModel::load(recipe, options, &first);
  EXPECT_TRUE(first.generated && first.interpreted);
  EXPECT_FALSE(first.compiled);
  const CompiledModel::Function fd = m.function(Output::forward_dynamics);
  const InterpretedModel code = interpreted_code_of(recipe);
  std::mt19937 rng(7);
  const auto fd_code = std::find_if(code.functions.begin(), code.functions.end(),
                                    [](const auto& f) { return f.name == "forward_dynamics"; });
  Arguments before = random_arguments(m, *fd_code, 1, rng), after = before;
  fd(before.in_ptr.data(), before.params.data(), before.out_ptr.data());
  ASSERT_TRUE(m.wait_for_compiled()) << m.engine_report();
  EXPECT_TRUE(fd.compiled());
  after.point();
  fd(after.in_ptr.data(), after.params.data(), after.out_ptr.data());
  for (size_t r = 0; r < before.out.size(); ++r)
    for (size_t e = 0; e < before.out[r].size(); ++e)
      EXPECT_TRUE(same_bits(before.out[r][e], after.out[r][e])) << r << " " << e;
  EXPECT_NE(m.engine_report().find("the compiled library loaded"), std::string::npos)
      << m.engine_report();
  StageReport second;
  const CompiledModel again = CompiledModel::load(recipe, options, &second);
  EXPECT_FALSE(second.generated || second.compiled || second.interpreted);
  EXPECT_STREQ(again.engine(), "compiled");
  fs::remove_all(cache);
}

// The functions a command calls first (CompileOptions::first_functions) serve compiled from a
// library of their own while the other units still compile (held back here by a compiler that
// waits 3 s before any other unit), with the interpreter's numbers; the whole library then
// takes over, and the cache holds it alone.
TEST(Interpreter, FirstFunctionsServeCompiledBeforeTheWholeLibrary) {
  const fs::path cache = fresh_cache("interpreter_first");
  const fs::path slow = cache.parent_path() / ("slow-c++-" + std::to_string(::getpid()));
  std::ofstream(slow) << "#!/bin/sh\ncase \"$*\" in *libmodel_[1-9].cpp*) sleep 3;; esac\n"
                      << "exec c++ \"$@\"\n";
  fs::permissions(slow, fs::perms::owner_all);
  const ModelRecipe recipe =
      ModelRecipe::load(std::string(SPACEARM_SOURCE_DIR) + "/models/paper_geared.yaml");
  CompileOptions options;
  options.cache_dir = cache.string();
  options.compiler = slow.string();
  options.engine = Engine::automatic;
  options.call_first(Output::forward_dynamics);
  const CompiledModel m = CompiledModel::load(recipe, options);
  const CompiledModel::Function fd = m.function(Output::forward_dynamics);
  const CompiledModel::Function mass = m.function(Output::mass_matrix);
  const auto t0 = std::chrono::steady_clock::now();
  while (!fd.compiled() && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(20))
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_TRUE(fd.compiled()) << m.engine_report();
  EXPECT_FALSE(mass.compiled());
  EXPECT_STREQ(m.engine(), "interpreter");
  EXPECT_NE(m.engine_report().find("forward_dynamics compiled first"), std::string::npos)
      << m.engine_report();
  // The compiled first function computes the interpreter's numbers.
  const InterpretedModel code = interpreted_code_of(recipe);
  const auto fd_code = std::find_if(code.functions.begin(), code.functions.end(),
                                    [](const auto& f) { return f.name == "forward_dynamics"; });
  std::mt19937 rng(11);
  CompileOptions interpreted;
  interpreted.engine = Engine::interpreter;
  const CompiledModel i = CompiledModel::load(recipe, interpreted);
  for (int trial = 0; trial < 8; ++trial) {
    Arguments a = random_arguments(m, *fd_code, 1, rng), b = a;
    b.point();
    fd(a.in_ptr.data(), a.params.data(), a.out_ptr.data());
    i.function(Output::forward_dynamics)(b.in_ptr.data(), b.params.data(), b.out_ptr.data());
    for (size_t e = 0; e < a.out[0].size(); ++e) EXPECT_TRUE(same_bits(a.out[0][e], b.out[0][e]));
  }
  ASSERT_TRUE(m.wait_for_compiled()) << m.engine_report();
  EXPECT_TRUE(mass.compiled());
  EXPECT_NE(m.engine_report().find("the compiled library loaded"), std::string::npos);
  for (const auto& entry : fs::recursive_directory_iterator(cache))
    EXPECT_NE(entry.path().filename(), "libfirst.so") << entry.path();
  fs::remove_all(cache);
  fs::remove(slow);
}

// A model dropped while its library compiles leaves the compile to finish: the next run hits the
// cache.
TEST(Interpreter, ADroppedModelLeavesItsLibraryInTheCache) {
  const fs::path cache = fresh_cache("interpreter_dropped");
  const ModelRecipe recipe =
      ModelRecipe::load(std::string(SPACEARM_SOURCE_DIR) + "/models/paper_reference.yaml");
  CompileOptions options;
  options.cache_dir = cache.string();
  options.engine = Engine::automatic;
  StageReport first, second;
  { const CompiledModel m = CompiledModel::load(recipe, options, &first); }
  EXPECT_TRUE(first.interpreted);
  finish_background_compiles();  // what a command does last
  EXPECT_EQ(background_compiles_running(), 0);
  options.engine = Engine::compiled;
  const CompiledModel m = CompiledModel::load(recipe, options, &second);
  EXPECT_FALSE(second.generated || second.compiled);
  fs::remove_all(cache);
}

// Without a compiler and with nothing cached, automatic still serves (the interpreter), and says
// why no library came; compiled refuses, naming the compiler.
TEST(Interpreter, AutomaticWithoutACompilerServesByTheInterpreter) {
  const fs::path cache = fresh_cache("interpreter_no_compiler");
  const ModelRecipe recipe =
      ModelRecipe::load(std::string(SPACEARM_SOURCE_DIR) + "/models/paper_reference.yaml");
  CompileOptions options;
  options.cache_dir = cache.string();
  options.compiler = "/nonexistent/c++";
  options.engine = Engine::automatic;
  const CompiledModel m = CompiledModel::load(recipe, options);
  EXPECT_STREQ(m.engine(), "interpreter");
  EXPECT_FALSE(m.wait_for_compiled());
  EXPECT_NE(m.engine_report().find("not found"), std::string::npos) << m.engine_report();
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(m.nq());
  EXPECT_EQ(m.mass_matrix(q, Eigen::Map<const Eigen::VectorXd>(
                                 m.nominal_parameters().data(),
                                 static_cast<Eigen::Index>(m.nominal_parameters().size())))
                .rows(),
            m.nv());
  options.engine = Engine::compiled;
  try {
    CompiledModel::load(recipe, options);
    ADD_FAILURE() << "loaded without a compiler";
  } catch (const CompileError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/c++"), std::string::npos) << e.what();
  }
  fs::remove_all(cache);
}

TEST(Interpreter, EngineNamesParseAndRefuseOthers) {
  EXPECT_EQ(parse_engine("auto"), Engine::automatic);
  EXPECT_EQ(parse_engine("interpreter"), Engine::interpreter);
  EXPECT_EQ(parse_engine("compiled"), Engine::compiled);
  try {
    parse_engine("fast");
    ADD_FAILURE();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--engine"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("fast"), std::string::npos);
  }
}

}  // namespace
}  // namespace spacearm
