// Compile time per output, and what each optimisation level buys per call (issue 54, item 3):
// every function of a model's C interface is printed in a translation unit of its own
// (PrintOptions::leading_units: unit 0 states the facts alone) and compiled the way the cache
// compiles it (compile_flags, the host's instruction set), at three levels:
//   -O1x  the cache's default, -O1 -fexpensive-optimizations;
//   -O2, -O3.
// compile/LEVEL/MODEL/FUNCTION times one compiler run; call/LEVEL/MODEL/FUNCTION the function's
// time per call from the library linked from that level's objects, on 64 random states in turn.
// prelude/... is what each unit pays before its function: the smallest unit (gear_ratios)
// compiled as printed, with a precompiled header of its #include lines, and that header's own
// compile. The table at the end gives each level's compile time and time per call over -O1x's.
//   build-bench/bench/bench_compile [--benchmark_filter=...]
#include <benchmark/benchmark.h>

#include <dlfcn.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "compiled_model.hpp"
#include "machine_context.hpp"
#include "recording_reporter.hpp"

namespace spacearm::bench {
namespace {

namespace fs = std::filesystem;
constexpr int kStates = 64;

std::map<std::string, double> g_seconds;  // fastest repetition per benchmark name
const std::vector<std::pair<std::string, std::string>> kLevels = {
    {"-O1x", kDefaultOptimization}, {"-O2", "-O2"}, {"-O3", "-O3"}};

double seconds(const std::string& name) {
  const auto it = g_seconds.find(name);
  return it == g_seconds.end() ? NAN : it->second;
}

double since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The work folder, made by mkdtemp (a predictable name under /tmp could be planted).
const fs::path& work_root() {
  static const fs::path root = [] {
    std::string name = (fs::temp_directory_path() / "spacearm-bench-compile-XXXXXX").string();
    if (!mkdtemp(name.data())) throw std::runtime_error("bench_compile: mkdtemp failed");
    return fs::path(name);
  }();
  return root;
}

// Runs a compiler command in the work folder (the paths are ours: no quoting needed).
void run(const std::string& command) {
  if (std::system(("cd '" + work_root().string() + "' && " + command).c_str()) != 0)
    throw std::runtime_error("bench_compile: failed: " + command);
}

std::string flags(const std::string& optimization) {
  std::string f = compile_flags(optimization) + instruction_set_flags(host_instruction_set());
  return f.replace(f.find(" -shared"), 8, "");  // objects here; the link adds it
}

// A model printed one function per unit, with its functions' sizes (interpreted code).
struct Printed {
  std::string name;
  std::vector<std::string> units;
  std::vector<std::string> functions;  // functions[u]: unit u's (unit 0: the facts)
  std::shared_ptr<const InterpretedModel> code;
  int quaternion_offset = -1, nq = 0;
  std::vector<double> nominal;
};

Printed print_model(const std::string& scene_file, const std::string& name) {
  const ModelRecipe recipe = ModelRecipe::load(scene_file);
  EmitOptions eo;
  eo.c_units = 1000;        // one function each
  eo.leading_units = {{}};  // unit 0: the facts alone
  eo.interpreted = true;    // the functions' sizes
  const EmittedModel e = recipe.emit(eo);
  Printed p{name,
            e.c_units,
            {""},
            e.interpreted,
            recipe.facts().quaternion_offset,
            recipe.facts().dims.nq,
            recipe.facts().nominal_parameters};
  for (size_t u = 1; u < e.c_unit_functions.size(); ++u) {
    if (e.c_unit_functions[u].size() != 1) throw std::logic_error("bench_compile: unit layout");
    p.functions.push_back(e.c_unit_functions[u][0]);
  }
  for (size_t u = 0; u < p.units.size(); ++u)
    std::ofstream(work_root() / (name + "_" + std::to_string(u) + ".cpp")) << p.units[u];
  return p;
}

std::string object(const std::string& model, size_t u, const std::string& level) {
  return model + "_" + std::to_string(u) + level + ".o";
}

void register_compiles(const Printed& p) {
  for (const auto& [level, optimization] : kLevels)
    for (size_t u = 0; u < p.units.size(); ++u)
      benchmark::RegisterBenchmark(
          ("compile/" + level + "/" + p.name + "/" + (u ? p.functions[u] : "(facts)")).c_str(),
          [=, name = p.name, level = level, optimization = optimization](benchmark::State& st) {
            for (auto _ : st) {
              const auto t0 = std::chrono::steady_clock::now();
              run("c++ " + flags(optimization) + " -c " + name + "_" + std::to_string(u) +
                  ".cpp -o " + object(name, u, level));
              st.SetIterationTime(since(t0));
            }
          })
          ->UseManualTime()
          ->Iterations(1)
          ->Unit(benchmark::kMillisecond);
}

// The library of one level's objects, linked and opened once.
void* library(const Printed& p, const std::string& level) {
  static std::map<std::string, void*> opened;
  const std::string key = p.name + level;
  if (opened.count(key)) return opened[key];
  std::string objects;
  for (size_t u = 0; u < p.units.size(); ++u) {
    if (!fs::exists(work_root() / object(p.name, u, level)))
      throw std::runtime_error("bench_compile: run the compile/ benchmarks of " + key + " first");
    objects += " " + object(p.name, u, level);
  }
  run("c++ -shared" + objects + " -o lib" + key + ".so " + kVectorTrigLibraries);
  void* handle = dlopen((work_root() / ("lib" + key + ".so")).c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) throw std::runtime_error(dlerror());
  return opened[key] = handle;
}

void register_calls(const Printed& p) {
  for (const auto& level_flags : kLevels)
    for (size_t u = 1; u < p.units.size(); ++u) {
      const std::string level = level_flags.first, function = p.functions[u];
      benchmark::RegisterBenchmark(
          ("call/" + level + "/" + p.name + "/" + function).c_str(), [=](benchmark::State& st) {
            using Raw = void (*)(const double* const*, const double*, double* const*);
            const auto raw =
                reinterpret_cast<Raw>(dlsym(library(p, level), ("spacearm_" + function).c_str()));
            const bool lanes =
                function.size() > 3 && function.substr(function.size() - 3) == kLanesSuffix;
            const std::string base = lanes ? function.substr(0, function.size() - 3) : function;
            const InterpretedFunction* f = nullptr;
            for (const auto& g : p.code->functions)
              if (g.name == base) f = &g;
            if (!raw || !f) return st.SkipWithError(("no function " + function).c_str());
            const int L = lanes ? 4 : 1;
            // Random inputs, q's quaternion (input 0 where it is q) of unit length.
            std::mt19937 rng(54);
            std::uniform_real_distribution<double> angle(-M_PI, M_PI);
            std::vector<std::vector<std::vector<double>>> in(kStates);
            for (auto& state : in) {
              for (int size : f->input_sizes) {
                state.emplace_back(L * size);
                for (double& x : state.back()) x = angle(rng);
              }
              if (p.quaternion_offset >= 0 && !state.empty() && f->input_sizes[0] == p.nq)
                for (int l = 0; l < L; ++l) {
                  double norm = 0;
                  for (int j = 0; j < 4; ++j)
                    norm += std::pow(state[0][L * (p.quaternion_offset + j) + l], 2);
                  for (int j = 0; j < 4; ++j)
                    state[0][L * (p.quaternion_offset + j) + l] /= std::sqrt(norm);
                }
            }
            std::vector<double> params;
            for (double v : p.nominal)
              for (int l = 0; l < L; ++l) params.push_back(v);
            std::vector<std::vector<double>> out;
            std::vector<double*> out_ptr;
            for (int size : f->result_sizes) out.emplace_back(L * size);
            for (auto& o : out) out_ptr.push_back(o.data());
            std::vector<std::vector<const double*>> in_ptr(kStates);
            for (int k = 0; k < kStates; ++k)
              for (const auto& v : in[k]) in_ptr[k].push_back(v.data());
            int k = 0;
            for (auto _ : st) {
              raw(in_ptr[k].data(), params.data(), out_ptr.data());
              benchmark::ClobberMemory();
              k = (k + 1) % kStates;
            }
          });
    }
}

// What a unit pays before its function: the smallest unit as printed, with a precompiled header
// of its #include lines, and that header's compile.
void register_prelude(const Printed& p) {
  size_t smallest = 1;
  for (size_t u = 1; u < p.units.size(); ++u)
    if (p.units[u].size() < p.units[smallest].size()) smallest = u;
  std::string includes;
  std::istringstream lines(p.units[smallest]);
  for (std::string line; std::getline(lines, line);)
    if (line.rfind("#include", 0) == 0) includes += line + "\n";
  const std::string stem = p.name + "_prelude";
  std::ofstream(work_root() / (stem + ".hpp")) << includes;
  const std::string source = p.name + "_" + std::to_string(smallest) + ".cpp";
  const std::string f = flags(kDefaultOptimization);
  const auto timed = [](const std::string& name, const std::string& command) {
    benchmark::RegisterBenchmark(name.c_str(),
                                 [=](benchmark::State& st) {
                                   for (auto _ : st) {
                                     const auto t0 = std::chrono::steady_clock::now();
                                     run(command);
                                     st.SetIterationTime(since(t0));
                                   }
                                 })
        ->UseManualTime()
        ->Iterations(1)
        ->Unit(benchmark::kMillisecond);
  };
  timed("prelude/as printed/" + p.name, "c++ " + f + " -c " + source + " -o " + stem + "_a.o");
  timed("prelude/header/" + p.name,
        "c++ " + f + " -x c++-header " + stem + ".hpp -o " + stem + ".hpp.gch");
  timed("prelude/precompiled/" + p.name, "c++ " + f + " -Winvalid-pch -include " + stem +
                                             ".hpp -c " + source + " -o " + stem + "_b.o");
}

void print_table(const std::vector<Printed>& models) {
  std::printf(
      "\nCompile time per output and time per call, by level (fastest repetition; ratios over "
      "-O1x, the cache's)\n%-18s %-34s %9s %7s %7s %10s %7s %7s\n",
      "model", "function", "-O1x (ms)", "-O2", "-O3", "call (ns)", "-O2", "-O3");
  for (const Printed& p : models) {
    if (std::isnan(seconds("compile/-O1x/" + p.name + "/(facts)"))) continue;  // filtered out
    double total[3] = {0, 0, 0};
    for (size_t u = 0; u < p.units.size(); ++u) {
      const std::string f = u ? p.functions[u] : "(facts)";
      double c[3], t[3];
      for (int l = 0; l < 3; ++l) {
        c[l] = seconds("compile/" + kLevels[l].first + "/" + p.name + "/" + f);
        t[l] = seconds("call/" + kLevels[l].first + "/" + p.name + "/" + f);
        total[l] += c[l];
      }
      std::printf("%-18s %-34s %9.0f %7.2f %7.2f %10.0f %7.2f %7.2f\n", p.name.c_str(), f.c_str(),
                  c[0] * 1e3, c[1] / c[0], c[2] / c[0], t[0] * 1e9, t[1] / t[0], t[2] / t[0]);
    }
    std::printf("%-18s %-34s %9.0f %7.2f %7.2f\n", p.name.c_str(), "(all units, one at a time)",
                total[0] * 1e3, total[1] / total[0], total[2] / total[0]);
    std::printf(
        "%-18s prelude: a unit as printed %.0f ms, with a precompiled header %.0f ms "
        "(the header: %.0f ms)\n",
        p.name.c_str(), seconds("prelude/as printed/" + p.name) * 1e3,
        seconds("prelude/precompiled/" + p.name) * 1e3, seconds("prelude/header/" + p.name) * 1e3);
  }
}

}  // namespace
}  // namespace spacearm::bench

int main(int argc, char** argv) {
  using namespace spacearm::bench;
  const std::string scenes = SPACEARM_SOURCE_DIR "/bench/scenes/";
  std::vector<Printed> models;
  for (const auto& [file, name] : std::vector<std::pair<std::string, std::string>>{
           {SPACEARM_SOURCE_DIR "/models/paper_geared.yaml", "paper_geared"},
           {scenes + "chain_n30_geared.yaml", "chain_n30_geared"},
           {SPACEARM_SOURCE_DIR "/models/space_arm7.yaml", "space_arm7"}})
    models.push_back(print_model(file, name));
  for (const auto& p : models) register_compiles(p), register_prelude(p);
  for (const auto& p : models) register_calls(p);
  benchmark::Initialize(&argc, argv);
  add_machine_context();
  RecordingReporter reporter(g_seconds);
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  print_table(models);
  fs::remove_all(work_root());
  return 0;
}
