// Python overhead of a batched call (issue 15's goal: at most 10 % over the C++ call): the mass
// matrix of the paper's geared model for k states through the numpy binding
// (model.mass_matrix(Q) in an embedded interpreter) against the same states through the loaded
// library from C++: the checked batch (CompiledModel::evaluate_batch, what the binding calls)
// and the unchecked exported function in a loop. Items: states.
#include <benchmark/benchmark.h>
#include <pybind11/embed.h>
#include <pybind11/numpy.h>

#include <cstdlib>
#include <random>

#include "machine_context.hpp"
#include "compiled_model.hpp"

namespace py = pybind11;

namespace {

constexpr const char* kScene = SPACEARM_SOURCE_DIR "/models/paper_geared.yaml";
constexpr int kNq = 6;

std::string cache_dir() {
  const char* dir = std::getenv("SPACEARM_CACHE_DIR");
  return dir ? dir : "";
}

const spacearm::CompiledModel& model() {
  static const spacearm::CompiledModel m = [] {
    spacearm::CompileOptions options;
    options.cache_dir = cache_dir();
    return spacearm::CompiledModel::load(spacearm::load_scene(kScene), options);
  }();
  return m;
}

// k random configurations, row after row.
std::vector<double> states(long k) {
  std::mt19937_64 gen(1);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> q(k * kNq);
  for (double& v : q) v = u(gen);
  return q;
}

Eigen::VectorXd params() {
  const auto& p = model().nominal_parameters();
  Eigen::VectorXd v = Eigen::Map<const Eigen::VectorXd>(p.data(), p.size());
  v[0] = 10;  // p
  return v;
}

void BM_Unchecked_CppLoop(benchmark::State& state) {
  const long k = state.range(0);
  const std::vector<double> q = states(k);
  std::vector<double> M(k * kNq * kNq);
  const auto f = model().function(spacearm::Output::mass_matrix);
  const Eigen::VectorXd p = params();
  for (auto _ : state)
    for (long s = 0; s < k; ++s) {
      const double* in[] = {q.data() + s * kNq};
      double* out[] = {M.data() + s * kNq * kNq};
      f(in, p.data(), out);
    }
  benchmark::DoNotOptimize(M.data());
  state.SetItemsProcessed(state.iterations() * k);
}

void BM_Checked_CppBatch(benchmark::State& state) {
  const long k = state.range(0);
  const std::vector<double> q = states(k);
  std::vector<double> M(k * kNq * kNq);
  const Eigen::VectorXd p = params();
  for (auto _ : state)
    model().evaluate_batch(spacearm::Output::mass_matrix, k, {q.data()}, p, {M.data()});
  benchmark::DoNotOptimize(M.data());
  state.SetItemsProcessed(state.iterations() * k);
}

// The model through the binding (spacearm.load, p = 10), and k states as a (k, n) array.
py::object python_model() {
  py::dict given;
  given["p"] = 10.0;
  return py::module_::import("spacearm").attr("load")(kScene, given, cache_dir());
}
py::array_t<double> python_states(const std::vector<double>& v, long k) {
  py::array_t<double> a({k, static_cast<long>(kNq)});
  std::copy(v.begin(), v.end(), a.mutable_data());
  return a;
}

void BM_Checked_PythonBatch(benchmark::State& state) {
  const long k = state.range(0);
  const py::array_t<double> Q = python_states(states(k), k);
  py::object mass_matrix = python_model().attr("mass_matrix");
  for (auto _ : state) benchmark::DoNotOptimize(mass_matrix(Q).ptr());
  state.SetItemsProcessed(state.iterations() * k);
}

BENCHMARK(BM_Unchecked_CppLoop)->Arg(1000);
BENCHMARK(BM_Checked_CppBatch)->Arg(1000);
BENCHMARK(BM_Checked_PythonBatch)->Arg(1000);

// Forward dynamics of k states (issue 33's goals: from Python at most 1.2x the scalar generated
// function alone; on 4 lanes at least 2.5x faster than it): the unchecked scalar function in a
// loop, and model.forward_dynamics(q, qd, Q) with model.lanes = 1 and 4.
void BM_ForwardDynamics_Unchecked_CppLoop(benchmark::State& state) {
  const long k = state.range(0);
  const std::vector<double> q = states(k), qd = states(k), Q = states(k);
  std::vector<double> qdd(k * kNq), pivots(k * kNq), scaled(k * kNq);
  const auto f = model().function(spacearm::Output::forward_dynamics);
  const Eigen::VectorXd p = params();
  for (auto _ : state)
    for (long s = 0; s < k; ++s) {
      const double* in[] = {q.data() + s * kNq, qd.data() + s * kNq, Q.data() + s * kNq};
      double* out[] = {qdd.data() + s * kNq, pivots.data() + s * kNq, scaled.data() + s * kNq};
      f(in, p.data(), out);
    }
  benchmark::DoNotOptimize(qdd.data());
  state.SetItemsProcessed(state.iterations() * k);
}

// The 4-lane function alone, on arrays already interleaved (entry i of lane l at [4 i + l]): the
// bound of the 4-lane batch, which also transposes each state in and out and checks it.
void BM_ForwardDynamics_Unchecked_LanesLoop(benchmark::State& state) {
  const long k = state.range(0);
  const std::vector<double> q = states(k), qd = states(k), Q = states(k);
  std::vector<double> qdd(k * kNq), pivots(k * kNq), scaled(k * kNq);
  const auto f = model().lanes_function(spacearm::Output::forward_dynamics);
  std::vector<double> p;
  for (double v : params()) p.insert(p.end(), 4, v);
  for (auto _ : state)
    for (long s = 0; s + 4 <= k; s += 4) {
      const double* in[] = {q.data() + s * kNq, qd.data() + s * kNq, Q.data() + s * kNq};
      double* out[] = {qdd.data() + s * kNq, pivots.data() + s * kNq, scaled.data() + s * kNq};
      f(in, p.data(), out);
    }
  benchmark::DoNotOptimize(qdd.data());
  state.SetItemsProcessed(state.iterations() * k);
}

// The checked batch from C++ (CompiledModel::evaluate_batch, what the binding calls, with qdd
// alone kept), into arrays allocated once: the binding's own cost is the difference.
void BM_ForwardDynamics_Checked_CppBatch(benchmark::State& state) {
  const long k = state.range(0);
  const std::vector<double> q = states(k), qd = states(k), Q = states(k);
  std::vector<double> qdd(k * kNq);
  const Eigen::VectorXd p = params();
  const int lanes = static_cast<int>(state.range(1));
  for (auto _ : state)
    model().evaluate_batch(spacearm::Output::forward_dynamics, k, {q.data(), qd.data(), Q.data()},
                           p, {qdd.data(), nullptr, nullptr}, lanes);
  benchmark::DoNotOptimize(qdd.data());
  state.SetItemsProcessed(state.iterations() * k);
}

void BM_ForwardDynamics_Checked_PythonBatch(benchmark::State& state) {
  const long k = state.range(0);
  py::object m = python_model();
  m.attr("lanes") = state.range(1);
  const py::array_t<double> q = python_states(states(k), k), qd = python_states(states(k), k),
                            Q = python_states(states(k), k);
  py::object forward_dynamics = m.attr("forward_dynamics");
  for (auto _ : state) benchmark::DoNotOptimize(forward_dynamics(q, qd, Q).ptr());
  state.SetItemsProcessed(state.iterations() * k);
}

BENCHMARK(BM_ForwardDynamics_Unchecked_CppLoop)->Arg(10000);
BENCHMARK(BM_ForwardDynamics_Unchecked_LanesLoop)->Arg(10000);
BENCHMARK(BM_ForwardDynamics_Checked_CppBatch)
    ->ArgNames({"states", "lanes"})
    ->Args({10000, 1})
    ->Args({10000, 4});
BENCHMARK(BM_ForwardDynamics_Checked_PythonBatch)
    ->ArgNames({"states", "lanes"})
    ->Args({10000, 1})
    ->Args({10000, 4});

}  // namespace

int main(int argc, char** argv) {
  py::scoped_interpreter python;
  py::module_::import("sys").attr("path").attr("insert")(0, SPACEARM_PYTHON_DIR);
  model();  // compile (or load) before timing
  benchmark::Initialize(&argc, argv);
  spacearm::bench::add_machine_context();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
}
