#!/usr/bin/env bash
# Builds and runs the benchmarks: per-call cost against MuJoCo, SymPy (with cse) and the
# CSE-free baseline, with the ratio table at the end. Installs Google Benchmark, MuJoCo and
# SymPy when missing.
#   scripts/bench.sh [--quick] [benchmark options, e.g. --benchmark_filter=chain_n3]
# --quick: only the MuJoCo comparison for N = 3, 12 and 30 (reference, geared, armature) and
# the paper's models; a few minutes from a clean clone (build folder build-bench-quick).
# Build folder: build-bench (Release). Results vary with the machine and its load: compare
# ratios measured in one run, not absolute times across machines.
set -euo pipefail
cd "$(dirname "$0")/.."
quick=0
if [[ "${1:-}" == "--quick" ]]; then
  quick=1
  shift
fi
if ((quick)); then
  scripts/install-packages.sh libbenchmark-dev libmujoco-dev
  scripts/setup.sh build-bench-quick -DSPACEARM_BUILD_BENCH=ON -DSPACEARM_BENCH_QUICK=ON -DSPACEARM_BUILD_TESTS=OFF
  binary=build-bench-quick/bench/bench_dynamics
else
  scripts/install-packages.sh libbenchmark-dev libmujoco-dev python3-sympy python3-yaml
  # Debian's python3 and python3-sympy, not whatever python3 comes first on PATH.
  scripts/setup.sh build-bench -DSPACEARM_BUILD_BENCH=ON -DSPACEARM_BUILD_TESTS=OFF -DPython3_EXECUTABLE=/usr/bin/python3
  binary=build-bench/bench/bench_dynamics
fi
# Five repetitions, interleaved at random so that a slow spell of the machine does not hit one
# benchmark only; the ratio table takes each one's fastest repetition. Options given override.
"$binary" --benchmark_repetitions=5 --benchmark_enable_random_interleaving=true --benchmark_min_time=0.1 "$@"
