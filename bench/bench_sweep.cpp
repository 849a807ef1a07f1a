// Sweep throughput (issue 15's goals): runs of studies/paper_monte_carlo.yaml (the paper's 10 s
// manoeuvre, RK4 at 0.01 s, geared model with random p, I_m and link masses) per second on 1
// and 2 threads. The ratio of the two in one run is the scaling; 10 000 / (runs per second) the
// Monte Carlo's time.
#include <benchmark/benchmark.h>

#include <atomic>
#include <cstdlib>
#include <thread>
#include <vector>

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

// Each iteration: the next 32 runs on `threads` threads, each taking the next run as the pool of
// `spacearm sweep` does. Items: runs; the rate is in wall time.
void BM_MonteCarloRuns(benchmark::State& state) {
  const spacearm::StudyRunner& r = runner();
  const int threads = static_cast<int>(state.range(0));
  const long n = r.study().num_runs(), batch = 32;
  long first = 0;
  for (auto _ : state) {
    std::atomic<long> next{first};
    const long group = std::max(1, r.lanes());  // as spacearm sweep takes them
    auto work = [&] {
      for (long k; (k = next.fetch_add(group)) < first + batch;) {
        std::vector<long> runs;
        for (long j = k; j < std::min(first + batch, k + group); ++j) runs.push_back(j % n);
        benchmark::DoNotOptimize(r.rows(runs).size());
      }
    };
    std::vector<std::thread> pool;
    for (int t = 1; t < threads; ++t) pool.emplace_back(work);
    work();
    for (auto& t : pool) t.join();
    first += batch;
  }
  state.SetItemsProcessed(state.iterations() * batch);
}
BENCHMARK(BM_MonteCarloRuns)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->MinTime(2.0);

}  // namespace

int main(int argc, char** argv) {
  runner();  // compile (or load) before timing
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
}
