// Sweep throughput (issues 15 and 33): runs of studies/paper_monte_carlo.yaml (the paper's 10 s
// manoeuvre, RK4 at 0.01 s, geared model with random p, I_m and link masses) per second, in one
// run of this program:
//   BM_MonteCarloRuns/threads/lanes   spacearm's runs on 1 and 2 threads; lanes 0 is the
//                                     reference path (every check on every call, an allocating
//                                     dynamic-size model), 1 the lockstep path one run at a
//                                     time, 4 four runs per call of the 4-lane functions
//   BM_ForwardDynamicsOfARun/lanes    a run's 4000 forward-dynamics calls alone (1000 steps x 4
//                                     stages) of the generated function, scalar or 4-lane
//                                     (1000 calls of four states): a run's floor
//   BM_MujocoMonteCarloRuns/threads   the same study in MuJoCo: its armature model of the geared
//                                     joints (I_m p^2 on each joint) with each run's p, I_m and
//                                     masses, mj_step with RK4 at 0.01 s, the same torques
//                                     (held over each step, as MuJoCo applies forces) and the
//                                     end effector read at every step
// Items are runs; 10 000 / (runs per second) is the Monte Carlo's time.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <thread>
#include <vector>

#include "machine_context.hpp"
#include "mujoco_chain.hpp"
#include "outputs.hpp"
#include "sweep.hpp"

namespace {

const spacearm::StudyRunner& runner() {
  static const spacearm::StudyRunner r = [] {
    spacearm::CompileOptions options;
    if (const char* dir = std::getenv("SPACEARM_CACHE_DIR")) options.cache_dir = dir;
    return spacearm::StudyRunner(
        spacearm::load_study(SPACEARM_SOURCE_DIR "/studies/paper_monte_carlo.yaml"), options);
  }();
  return r;
}

// Each iteration: the next 32 runs on `threads` threads, each taking the next group of runs as
// the pool of `spacearm sweep` does (run(worker, k, end): runs k to end - 1 on worker 0 .. threads
// - 1). Items: runs, in wall time.
template <class Run>
void runs_on_threads(benchmark::State& state, int threads, long group, Run&& run) {
  const long batch = 32;
  long first = 0;
  for (auto _ : state) {
    std::atomic<long> next{first};
    auto work = [&](int worker) {
      for (long k; (k = next.fetch_add(group)) < first + batch;)
        run(worker, k, std::min(first + batch, k + group));
    };
    std::vector<std::thread> pool;
    for (int t = 1; t < threads; ++t) pool.emplace_back(work, t);
    work(0);
    for (auto& t : pool) t.join();
    first += batch;
  }
  state.SetItemsProcessed(state.iterations() * batch);
}

void BM_MonteCarloRuns(benchmark::State& state) {
  const spacearm::StudyRunner& r = runner();
  const_cast<spacearm::StudyRunner&>(r).set_lanes(static_cast<int>(state.range(1)));
  const long n = r.study().num_runs();
  runs_on_threads(state, static_cast<int>(state.range(0)), std::max(1, r.lanes()),
                  [&](int, long k, long end) {
                    std::vector<long> runs;
                    for (long j = k; j < end; ++j) runs.push_back(j % n);
                    benchmark::DoNotOptimize(r.rows(runs).size());
                  });
}
BENCHMARK(BM_MonteCarloRuns)
    ->ArgNames({"threads", "lanes"})
    ->ArgsProduct({{1, 2}, {0, 1, 4}})
    ->UseRealTime()
    ->MinTime(2.0);

// A run's forward-dynamics calls: 4000 states along a path (the first state's angles moved a
// little at each call), the first run's parameters; four states per call on 4 lanes.
void BM_ForwardDynamicsOfARun(benchmark::State& state) {
  const spacearm::StudyRunner& r = runner();
  const spacearm::CompiledModel& m = r.model();
  const int lanes = static_cast<int>(state.range(0)), nv = m.nv();
  const auto f = lanes == 4 ? m.lanes_function(spacearm::Output::forward_dynamics)
                            : m.function(spacearm::Output::forward_dynamics);
  if (!f) return state.SkipWithError("the model has no 4-lane forward dynamics");
  const Eigen::VectorXd params = r.study().parameters(0), start = r.start_link_side();
  std::vector<double> q(nv * lanes), qd(nv * lanes, 0.1), Q(nv * lanes, 0.01), p, qdd(nv * lanes),
      pivots(nv * lanes), scaled(nv * lanes);
  for (double v : params) p.insert(p.end(), lanes, v);
  for (int i = 0; i < nv; ++i)
    for (int l = 0; l < lanes; ++l) q[i * lanes + l] = start[i] * (i >= 3 ? params[0] : 1);
  const double* in[] = {q.data(), qd.data(), Q.data()};
  double* out[] = {qdd.data(), pivots.data(), scaled.data()};
  for (auto _ : state)
    for (int call = 0; call < 4000 / lanes; ++call) {
      for (int l = 0; l < lanes; ++l) q[3 * lanes + l] += 1e-4;
      f(in, p.data(), out);
      benchmark::DoNotOptimize(qdd.data());
    }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_ForwardDynamicsOfARun)->ArgName("lanes")->Arg(1)->Arg(4)->MinTime(1.0);

// The study in MuJoCo: per thread a copy of the armature model, set to each run's parameters.
void BM_MujocoMonteCarloRuns(benchmark::State& state) {
  const spacearm::StudyRunner& r = runner();
  const spacearm::Scene& scene = *r.study().scene.planar;
  const spacearm::bench::MujocoModel nominal(spacearm::bench::mjcf_of(scene));
  const std::vector<std::string>& names = r.study().scene.parameter_names;
  auto index = [&](const std::string& name) {
    return static_cast<int>(std::find(names.begin(), names.end(), name) - names.begin());
  };
  const int p_at = index("p"), im_at = index("Im");  // the link inertia compensates I_m
  const int N = scene.num_links(), steps = static_cast<int>(std::lround(r.study().t_end / 0.01));
  const Eigen::VectorXd start = r.start_link_side();
  const spacearm::TorqueSignal<Eigen::Dynamic>& tau = r.torques();
  const int threads = static_cast<int>(state.range(0));
  std::vector<spacearm::bench::MujocoModel> models;
  for (int t = 0; t < threads; ++t) models.emplace_back(spacearm::bench::mjcf_of(scene));
  const double nominal_im = r.model().nominal_parameters().at(im_at);
  runs_on_threads(state, threads, 1, [&](int worker, long k, long) {
    const spacearm::bench::MujocoModel& mm = models[worker];
    mjModel* m = mm.m.get();
    mjData* d = mm.d.get();
    const Eigen::VectorXd params = r.study().parameters(k % r.study().num_runs());
    const double p = params[p_at], Im = params[im_at];
    m->opt.timestep = 0.01;
    for (int i = 0; i < N; ++i) {
      const int body = 2 + i;  // world, base, link 1, ...
      m->body_mass[body] = params[index("m" + std::to_string(i + 1))];
      for (int a = 0; a < 3; ++a)
        m->body_inertia[3 * body + a] = nominal.m->body_inertia[3 * body + a] + nominal_im - Im;
      m->dof_armature[3 + i] = Im * p * p;
    }
    mj_resetData(m, d);
    for (int i = 0; i < 3 + N; ++i) d->qpos[i] = start[i];
    Eigen::VectorXd torque(N);
    double ee = 0;
    for (int s = 0; s < steps; ++s) {
      tau.evaluate(0.01 * s, torque);
      for (int i = 0; i < N; ++i) d->qfrc_applied[3 + i] = torque[i];
      mj_step(m, d);
      ee += d->xpos[3 * (m->nbody - 1)];
    }
    benchmark::DoNotOptimize(ee);
  });
}
BENCHMARK(BM_MujocoMonteCarloRuns)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(2.0);

}  // namespace

int main(int argc, char** argv) {
  runner();  // compile (or load) before timing
  benchmark::Initialize(&argc, argv);
  spacearm::bench::add_machine_context();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
}
