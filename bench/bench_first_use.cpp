// First use against speed per call: how long a new scene takes to its first forward-dynamics
// result, and what each call costs after that, for the ways spacearm could run a scene it has
// not seen before:
//   jit -O0 / -O1 / -O2  the compile-and-load path (generate, compile the C interface, dlopen)
//                        with each optimisation level; the default is -O1;
//   interpreted          no compiler: the lowered straight-line program run by a loop over its
//                        nodes in this process (latency: derive + lower);
//   linked               the peer: the same model generated at build time and compiled by CMake
//                        into this binary (Eigen, -O2), called directly.
// Per-call times are over a fixed set of random states; the table at the end gives each
// option's time per call over the linked model's, measured in this process.
//   build-bench/bench/bench_first_use [--benchmark_filter=...]
#include <benchmark/benchmark.h>

#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
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

// Random states (q, qd, Q) of a model with nq = nv = n, as one flat array each.
struct States {
  std::vector<std::vector<double>> q, qd, Q;
  explicit States(int n) {
    std::mt19937 rng(2024);
    std::uniform_real_distribution<double> angle(-M_PI, M_PI), rate(-1, 1);
    for (int k = 0; k < kStates; ++k) {
      q.emplace_back(n), qd.emplace_back(n), Q.emplace_back(n);
      for (int i = 0; i < n; ++i) q[k][i] = angle(rng), qd[k][i] = rate(rng), Q[k][i] = rate(rng);
    }
  }
};

// The in-process option: the lowered forward_dynamics program, scheduled once and run node by
// node by Program::evaluate (what an interpreter of the straight-line program would do).
class Interpreter {
 public:
  explicit Interpreter(const FunctionSpec& f) : f_(f), order_(f.program.schedule(f.roots())) {
    for (const auto& a : f.inputs) slots_.push_back(a.name);
    slots_.push_back("params");
  }
  // inputs: one array per slot (q, qd, Q, params); returns qdd.
  std::vector<double> run(const std::vector<const double*>& inputs) const {
    return f_.program.evaluate(order_, f_.entries[0], [&](const std::string& name, int i) {
      for (size_t k = 0; k < slots_.size(); ++k)
        if (slots_[k] == name) return inputs[k][i];
      throw std::logic_error("interpreter: unknown input " + name);
    });
  }

 private:
  const FunctionSpec& f_;
  std::vector<int> order_;
  std::vector<std::string> slots_;
};

const FunctionSpec& forward_dynamics_spec(const LoweredModel& lowered) {
  for (const auto& f : lowered.functions)
    if (f.name == "forward_dynamics") return f;
  throw std::logic_error("the scene does not emit forward_dynamics");
}

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

CompileOptions options(const std::string& level) {
  CompileOptions o;
  o.flags = compile_flags(level);
  return o;
}

void register_jit(const std::string& scene_file, const std::string& name,
                  const std::string& level) {
  const std::string label = "jit " + level;
  // First use: a new cache folder, then generate, compile, load and one call.
  benchmark::RegisterBenchmark(
      ("first/" + label + "/" + name).c_str(),
      [=](benchmark::State& st) {
        const Scene scene = load_scene(scene_file);
        const States s(scene.num_velocities());
        for (auto _ : st) {
          const std::string cache = fresh_cache();
          const auto t0 = std::chrono::steady_clock::now();
          CompileOptions o = options(level);
          o.cache_dir = cache;
          const CompiledModel m = CompiledModel::load(scene, o);
          const Eigen::VectorXd p = Eigen::Map<const Eigen::VectorXd>(
              m.nominal_parameters().data(), m.nominal_parameters().size());
          auto qdd =
              m.forward_dynamics(Eigen::Map<const Eigen::VectorXd>(s.q[0].data(), m.nq()),
                                 Eigen::Map<const Eigen::VectorXd>(s.qd[0].data(), m.nv()),
                                 Eigen::Map<const Eigen::VectorXd>(s.Q[0].data(), m.nv()), p);
          benchmark::DoNotOptimize(qdd);
          st.SetIterationTime(
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
          fs::remove_all(cache);
        }
      })
      ->UseManualTime()
      ->Iterations(1)
      ->Unit(benchmark::kMillisecond);
  // Per call: the exported C function, unchecked, on the states in turn.
  benchmark::RegisterBenchmark(("call/" + label + "/" + name).c_str(), [=](benchmark::State& st) {
    const Scene scene = load_scene(scene_file);
    const std::string cache = fresh_cache();
    CompileOptions o = options(level);
    o.cache_dir = cache;
    const CompiledModel m = CompiledModel::load(scene, o);
    const auto f = m.function(Output::forward_dynamics);
    const States s(m.nv());
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

void register_interpreted(const std::string& scene_file, const std::string& name) {
  benchmark::RegisterBenchmark(
      ("first/interpreted/" + name).c_str(),
      [=](benchmark::State& st) {
        const Scene scene = load_scene(scene_file);
        const States s(scene.num_velocities());
        for (auto _ : st) {
          const auto t0 = std::chrono::steady_clock::now();
          const LoweredModel lowered = lower(derive(scene));
          const Interpreter run(forward_dynamics_spec(lowered));
          const std::vector<double> qdd = run.run({s.q[0].data(), s.qd[0].data(), s.Q[0].data(),
                                                   lowered.facts.nominal_parameters.data()});
          benchmark::DoNotOptimize(qdd.data());
          st.SetIterationTime(
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
        }
      })
      ->UseManualTime()
      ->Iterations(1)
      ->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark(("call/interpreted/" + name).c_str(), [=](benchmark::State& st) {
    const Scene scene = load_scene(scene_file);
    const LoweredModel lowered = lower(derive(scene));
    const Interpreter run(forward_dynamics_spec(lowered));
    const States s(scene.num_velocities());
    int k = 0;
    for (auto _ : st) {
      const std::vector<double> qdd = run.run(
          {s.q[k].data(), s.qd[k].data(), s.Q[k].data(), lowered.facts.nominal_parameters.data()});
      benchmark::DoNotOptimize(qdd.data());
      k = (k + 1) % kStates;
    }
  });
}

// The peer: the generated model linked into this binary, its forward_dynamics called directly.
template <class G>
void register_linked(const std::string& name) {
  benchmark::RegisterBenchmark(("call/linked/" + name).c_str(), [](benchmark::State& st) {
    using V = typename G::template Velocities<double>;
    using C = typename G::template Coordinates<double>;
    const States s(G::kNv);
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

double seconds(const std::string& name) {
  auto it = g_seconds.find(name);
  return it == g_seconds.end() ? NAN : it->second;
}

void print_table(const std::vector<std::string>& models) {
  std::printf(
      "\nFirst result against time per call (fastest repetition; per call also over the linked "
      "model's)\n%-18s %-12s %14s %12s %10s\n",
      "model", "option", "first (ms)", "call (ns)", "/ linked");
  for (const auto& model : models) {
    const double linked = seconds("call/linked/" + model);
    std::printf("%-18s %-12s %14s %12.0f %10.2f\n", model.c_str(), "linked", "(build time)",
                linked * 1e9, 1.0);
    for (const std::string option : {"jit -O0", "jit -O1", "jit -O2", "interpreted"}) {
      const double first = seconds("first/" + option + "/" + model),
                   call = seconds("call/" + option + "/" + model);
      std::printf("%-18s %-12s %14.0f %12.0f %10.2f\n", model.c_str(), option.c_str(), first * 1e3,
                  call * 1e9, call / linked);
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
      {scenes + "chain_n30_geared.yaml", "chain_n30_geared"}};
  register_linked<m::paper_geared::Model>("paper_geared");
  register_linked<m::chain_n12_geared::Model>("chain_n12_geared");
  register_linked<m::chain_n30_geared::Model>("chain_n30_geared");
  std::vector<std::string> names;
  for (const auto& [file, name] : models) {
    for (const char* level : {"-O0", "-O1", "-O2"}) register_jit(file, name, level);
    register_interpreted(file, name);
    names.push_back(name);
  }
  // The first load in a process also hashes the running executable (the cache key's generator
  // identity, once per process): done here, so no benchmark's first result carries it.
  spacearm::CompileOptions warm_up;
  warm_up.cache_dir = fresh_cache();
  spacearm::CompiledModel::load(spacearm::load_scene(models[0].first), warm_up);
  benchmark::Initialize(&argc, argv);
  spacearm::bench::add_machine_context();
  RecordingReporter reporter(g_seconds);
  benchmark::RunSpecifiedBenchmarks(&reporter);
  print_table(names);
  fs::remove_all(cache_root());
  benchmark::Shutdown();
  return 0;
}
