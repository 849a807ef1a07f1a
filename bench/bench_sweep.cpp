// Sweep throughput (issue 15's goals): runs of studies/paper_monte_carlo.yaml (the paper's 10 s
// manoeuvre, RK4 at 0.01 s, geared model with random p, I_m and link masses) per second on 1
// and 2 threads, each thread taking the next run as `spacearm sweep`'s pool does. The ratio of
// the two in one run is the scaling; 10 000 / (runs per second) the Monte Carlo's time.
#include <benchmark/benchmark.h>

#include <atomic>
#include <cstdlib>

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

std::atomic<long> next_run{0};

void BM_MonteCarloRuns(benchmark::State& state) {
  const spacearm::StudyRunner& r = runner();
  const long n = r.study().num_runs();
  size_t bytes = 0;
  for (auto _ : state) bytes += r.row(next_run++ % n).size();
  benchmark::DoNotOptimize(bytes);
  state.SetItemsProcessed(state.iterations());  // items: runs
}
BENCHMARK(BM_MonteCarloRuns)->Threads(1)->Threads(2)->UseRealTime()->MinTime(2.0);

}  // namespace

int main(int argc, char** argv) {
  runner();  // compile (or load) before timing
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
}
