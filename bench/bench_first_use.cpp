// First use against speed per call: how long a new scene takes to its first forward-dynamics
// result, and what each call costs after that, for the ways spacearm runs a scene it has not
// seen before (compiled_model.hpp's engines):
//   jit -O0 / -O1 / -O2  --engine compiled: generate, compile the C interface, dlopen, then the
//                        first call, with each optimisation level; the default is -O1;
//   interpreter          --engine interpreter: generate, read the interpreted code, first call
//                        (jit/interpreter.hpp: the compiled code's numbers, no compiler);
//   auto                 --engine auto (the default): the interpreter's first result, and the
//                        times until the compiled forward_dynamics ("fd") and the whole library
//                        compiled in the background ("compiled") serve;
//   auto first           the same with forward_dynamics called first (CompileOptions::
//                        first_functions, what simulate asks): its own unit, compiled and loaded
//                        ahead of the rest;
//   linked               the peer: the same model generated at build time and compiled by CMake
//                        into this binary (Eigen, -O2), called directly (planar models).
// Per-call times are over a fixed set of random states; the table at the end gives each
// option's time per call over the compiled (-O1) function's and the linked model's, measured in
// this process.
//   build-bench/bench/bench_first_use [--benchmark_filter=...]
#include <benchmark/benchmark.h>

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "machine_context.hpp"
#include "compiled_model.hpp"
#include "cpp_emitter.hpp"
#include "planar_model.hpp"
#include "recording_reporter.hpp"
#include "planar_scene.hpp"
#include "symbolic_model.hpp"

#include "chain_n12_geared.hpp"
#include "chain_n30_geared.hpp"
#include "paper_geared.hpp"

namespace spacearm::bench {
namespace {

namespace fs = std::filesystem;
constexpr int kStates = 64;

std::map<std::string, double> g_seconds;  // fastest repetition per benchmark name
const std::vector<std::string> kOptions = {"jit -O0",     "jit -O1", "jit -O2",
                                           "interpreter", "auto",    "auto first"};

// Random states (q, qd, Q) of a model (nq coordinates, nv velocities; a unit quaternion where
// q has one), as one flat array each.
struct States {
  std::vector<std::vector<double>> q, qd, Q;
  States(int nq, int nv, int quaternion = -1) {
    std::mt19937 rng(2024);
    std::uniform_real_distribution<double> angle(-M_PI, M_PI), rate(-1, 1);
    for (int k = 0; k < kStates; ++k) {
      q.emplace_back(nq), qd.emplace_back(nv), Q.emplace_back(nv);
      for (int i = 0; i < nq; ++i) q[k][i] = angle(rng);
      for (int i = 0; i < nv; ++i) qd[k][i] = rate(rng), Q[k][i] = rate(rng);
      if (quaternion >= 0) {
        double norm = 0;
        for (int j = 0; j < 4; ++j) norm += q[k][quaternion + j] * q[k][quaternion + j];
        for (int j = 0; j < 4; ++j) q[k][quaternion + j] /= std::sqrt(norm);
      }
    }
  }
  explicit States(const CompiledModel& m) : States(m.nq(), m.nv(), m.quaternion_offset()) {}
};

// A fresh cache folder per build, so that every first use compiles: inside one private folder
// made by mkdtemp (a predictable name under /tmp could be planted by another user).
const std::string& cache_root() {
  static const std::string root = [] {
    std::string name = (fs::temp_directory_path() / "spacearm-bench-first-use-XXXXXX").string();
    if (!mkdtemp(name.data())) throw std::runtime_error("bench_first_use: mkdtemp failed");
    return name;
  }();
  return root;
}
std::string fresh_cache() {
  static int count = 0;
  return cache_root() + "/cache-" + std::to_string(count++);
}

double seconds(const std::string& name) {
  auto it = g_seconds.find(name);
  return it == g_seconds.end() ? NAN : it->second;
}

CompileOptions options(const std::string& option) {
  CompileOptions o;
  o.engine = option.rfind("auto", 0) == 0 ? Engine::automatic
             : option == "interpreter"    ? Engine::interpreter
                                          : Engine::compiled;
  if (option == "auto first") o.call_first(Output::forward_dynamics);
  if (option.rfind("jit ", 0) == 0) o.flags = compile_flags(option.substr(4));
  return o;
}

double since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// One forward-dynamics result through the checked call (what a command's first step does).
void first_result(const CompiledModel& m) {
  const States s(m);
  const Eigen::VectorXd p = Eigen::Map<const Eigen::VectorXd>(m.nominal_parameters().data(),
                                                              m.nominal_parameters().size());
  auto qdd = m.forward_dynamics(Eigen::Map<const Eigen::VectorXd>(s.q[0].data(), m.nq()),
                                Eigen::Map<const Eigen::VectorXd>(s.qd[0].data(), m.nv()),
                                Eigen::Map<const Eigen::VectorXd>(s.Q[0].data(), m.nv()), p);
  benchmark::DoNotOptimize(qdd);
}

// option: "jit -O1", "interpreter" or "auto". First use: a new cache folder, then the load and
// one call (auto: also the time until the compiled library serves, as "compiled/").
void register_option(const std::string& scene_file, const std::string& name,
                     const std::string& option) {
  benchmark::RegisterBenchmark(("first/" + option + "/" + name).c_str(),
                               [=](benchmark::State& st) {
                                 const ModelRecipe recipe = ModelRecipe::load(scene_file);
                                 for (auto _ : st) {
                                   const std::string cache = fresh_cache();
                                   const auto t0 = std::chrono::steady_clock::now();
                                   CompileOptions o = options(option);
                                   o.cache_dir = cache;
                                   const CompiledModel m = CompiledModel::load(recipe, o);
                                   first_result(m);
                                   st.SetIterationTime(since(t0));
                                   if (option.rfind("auto", 0) == 0) {
                                     // When the compiled forward_dynamics serves, then the whole
                                     // library.
                                     const auto fastest = [&](const std::string& key, double now) {
                                       const double before = seconds(key);
                                       g_seconds[key] =
                                           std::isnan(before) ? now : std::min(before, now);
                                     };
                                     const auto fd = m.function(Output::forward_dynamics);
                                     while (!fd.compiled() && since(t0) < 600)
                                       std::this_thread::sleep_for(std::chrono::milliseconds(1));
                                     fastest("fd compiled/" + option + "/" + name, since(t0));
                                     if (!m.wait_for_compiled())
                                       st.SkipWithError(m.engine_report().c_str());
                                     fastest("compiled/" + option + "/" + name, since(t0));
                                   }
                                   fs::remove_all(cache);
                                 }
                               })
      ->UseManualTime()
      ->Iterations(1)
      ->Unit(benchmark::kMillisecond);
  if (option.rfind("auto", 0) == 0) return;  // per call: the compiled function's
  // Per call: the exported function, unchecked, on the states in turn.
  benchmark::RegisterBenchmark(("call/" + option + "/" + name).c_str(), [=](benchmark::State& st) {
    const ModelRecipe recipe = ModelRecipe::load(scene_file);
    const std::string cache = fresh_cache();
    CompileOptions o = options(option);
    o.cache_dir = cache;
    const CompiledModel m = CompiledModel::load(recipe, o);
    const auto f = m.function(Output::forward_dynamics);
    const States s(m);
    std::vector<double> qdd(m.nv()), pivots(m.nv()), scaled(m.nv());
    double* out[] = {qdd.data(), pivots.data(), scaled.data()};
    int k = 0;
    for (auto _ : st) {
      const double* in[] = {s.q[k].data(), s.qd[k].data(), s.Q[k].data()};
      f(in, m.nominal_parameters().data(), out);
      benchmark::DoNotOptimize(qdd.data());
      benchmark::ClobberMemory();
      k = (k + 1) % kStates;
    }
    fs::remove_all(cache);
  });
}

// The peer: the generated model linked into this binary, its forward_dynamics called directly.
template <class G>
void register_linked(const std::string& name) {
  benchmark::RegisterBenchmark(("call/linked/" + name).c_str(), [](benchmark::State& st) {
    using V = typename G::template Velocities<double>;
    using C = typename G::template Coordinates<double>;
    const States s(G::kNv, G::kNv);
    std::vector<C> q;
    std::vector<V> qd, Q;
    for (int k = 0; k < kStates; ++k)
      q.emplace_back(s.q[k].data()), qd.emplace_back(s.qd[k].data()), Q.emplace_back(s.Q[k].data());
    typename G::template Parameters<double> params;
    for (int i = 0; i < G::kNumParams; ++i) params[i] = G::nominal_parameters()[i];
    V qdd, pivots, scaled;
    int k = 0;
    for (auto _ : st) {
      G::forward_dynamics(q[k], qd[k], Q[k], params, qdd, pivots, scaled);
      benchmark::DoNotOptimize(qdd);
      k = (k + 1) % kStates;
    }
  });
}

void print_table(const std::vector<std::string>& models) {
  std::printf(
      "\nFirst result, compiled forward_dynamics, compiled library, time per call (fastest "
      "repetition; per call over the compiled -O1 function's and the linked model's)\n%-18s %-12s "
      "%11s %10s %14s %10s %10s %9s\n",
      "model", "option", "first (ms)", "fd (ms)", "compiled (ms)", "call (ns)", "/ jit -O1",
      "/ linked");
  for (const auto& model : models) {
    const double linked = seconds("call/linked/" + model), o1 = seconds("call/jit -O1/" + model);
    if (!std::isnan(linked))
      std::printf("%-18s %-12s %11s %10s %14s %10.0f %10.2f %9.2f\n", model.c_str(), "linked",
                  "(build)", "(build)", "(build)", linked * 1e9, linked / o1, 1.0);
    for (const std::string& option : kOptions) {
      const bool automatic = option.rfind("auto", 0) == 0;
      const double first = seconds("first/" + option + "/" + model);
      const double compiled = automatic ? seconds("compiled/" + option + "/" + model)
                              : option == "interpreter" ? NAN
                                                        : first;
      const double fd = automatic ? seconds("fd compiled/" + option + "/" + model) : compiled;
      const double call = automatic ? o1 : seconds("call/" + option + "/" + model);
      std::printf("%-18s %-12s %11.0f %10.0f %14.0f %10.0f %10.2f %9.2f\n", model.c_str(),
                  option.c_str(), first * 1e3, fd * 1e3, compiled * 1e3, call * 1e9, call / o1,
                  call / linked);
    }
  }
}

}  // namespace
}  // namespace spacearm::bench

int main(int argc, char** argv) {
  using namespace spacearm::bench;
  namespace m = spacearm::models;
  const std::string scenes = SPACEARM_SOURCE_DIR "/bench/scenes/";
  const std::vector<std::pair<std::string, std::string>> models = {
      {SPACEARM_SOURCE_DIR "/models/paper_geared.yaml", "paper_geared"},
      {scenes + "chain_n12_geared.yaml", "chain_n12_geared"},
      {scenes + "chain_n30_geared.yaml", "chain_n30_geared"},
      {SPACEARM_SOURCE_DIR "/models/space_arm7.yaml", "space_arm7"}};
  register_linked<m::paper_geared::Model>("paper_geared");
  register_linked<m::chain_n12_geared::Model>("chain_n12_geared");
  register_linked<m::chain_n30_geared::Model>("chain_n30_geared");
  std::vector<std::string> names;
  for (const auto& [file, name] : models) {
    for (const std::string& option : kOptions) register_option(file, name, option);
    names.push_back(name);
  }
  // The first load in a process also hashes the running executable (the cache key's generator
  // identity, once per process): done here, so no benchmark's first result carries it.
  spacearm::CompileOptions warm_up;
  warm_up.cache_dir = fresh_cache();
  spacearm::CompiledModel::load(spacearm::ModelRecipe::load(models[0].first), warm_up);
  benchmark::Initialize(&argc, argv);
  spacearm::bench::add_machine_context();
  RecordingReporter reporter(g_seconds);
  benchmark::RunSpecifiedBenchmarks(&reporter);
  print_table(names);
  fs::remove_all(cache_root());
  benchmark::Shutdown();
  return 0;
}
