#!/usr/bin/env bash
# Builds and runs the benchmarks: per-call cost against MuJoCo, SymPy (with cse) and the
# CSE-free baseline, with the ratio table at the end. Installs Google Benchmark, MuJoCo and
# SymPy when missing.
#   scripts/bench.sh [--quick [--all-sizes] | --first-use | --compile | --sweep | --python | --spatial] [benchmark options, e.g. --benchmark_filter=chain_n3]
# --spatial: a 7-joint arm on a free base (models/space_arm7) against MuJoCo.
# --quick: only the MuJoCo comparison for N = 3, 12 and 30 (reference, geared, armature) and
# the paper's models; a few minutes from a clean clone (build folder build-bench-quick).
# --quick --all-sizes: the MuJoCo comparison at every N of bench/scenes, 2 to 30
# (build-bench-sizes; about 25 minutes to build on 2 cores), M + bias and forward dynamics only.
# --first-use: latency to the first result against time per call (bench/bench_first_use.cpp).
# --compile: compile time per output at -O1x/-O2/-O3 and each level's time per call
# (bench/bench_compile.cpp; about 4 minutes).
# --sweep: Monte Carlo runs per second on 1 and 2 threads (bench/bench_sweep.cpp).
# --python: a batched call from Python against the C++ calls (bench/bench_python_batch.cpp).
# Build folder: build-bench (Release). Results vary with the machine and its load: compare
# ratios measured in one run, not absolute times across machines.
set -euo pipefail
cd "$(dirname "$0")/.."
quick=0
folder=build-bench-quick
sizes=()
filter=()
program=bench_dynamics
if [[ "${1:-}" == "--quick" || "${1:-}" == "--first-use" || "${1:-}" == "--compile" || "${1:-}" == "--sweep" || "${1:-}" == "--python" || "${1:-}" == "--spatial" ]]; then
  quick=1
  [[ "$1" == "--first-use" ]] && program=bench_first_use
  [[ "$1" == "--compile" ]] && program=bench_compile
  [[ "$1" == "--sweep" ]] && program=bench_sweep
  [[ "$1" == "--python" ]] && program=bench_python_batch
  [[ "$1" == "--spatial" ]] && program=bench_spatial
  shift
  if [[ "${1:-}" == "--all-sizes" ]]; then
    folder=build-bench-sizes
    sizes=("-DSPACEARM_BENCH_SIZES=2;3;4;6;8;10;12;16;20;30")
    filter=("--benchmark_filter=FD|M\+bias")  # M + bias and forward dynamics; options given override
    shift
  fi
fi
if ((quick)); then
  scripts/install-packages.sh libbenchmark-dev libmujoco-dev
  scripts/setup.sh "$folder" -DSPACEARM_BUILD_BENCH=ON -DSPACEARM_BENCH_QUICK=ON -DSPACEARM_BUILD_TESTS=OFF "${sizes[@]}"
  binary=$folder/bench/$program
else
  scripts/install-packages.sh libbenchmark-dev libmujoco-dev python3-sympy python3-yaml
  # Debian's python3 and python3-sympy, not whatever python3 comes first on PATH.
  scripts/setup.sh build-bench -DSPACEARM_BUILD_BENCH=ON -DSPACEARM_BUILD_TESTS=OFF -DPython3_EXECUTABLE=/usr/bin/python3
  binary=build-bench/bench/bench_dynamics
fi
# Five repetitions, interleaved at random so that a slow spell of the machine does not hit one
# benchmark only; the ratio table takes each one's fastest repetition. Options given override.
"$binary" --benchmark_repetitions=5 --benchmark_enable_random_interleaving=true --benchmark_min_time=0.1 "${filter[@]}" "$@"
