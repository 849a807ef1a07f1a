#!/usr/bin/env bash
# Builds the scene fuzzer (clang, libFuzzer + ASan + UBSan) and runs it for a bounded time
# on the seed corpus (shipped scenes, test scenes, fuzz/seeds, fuzz/regressions).
#   scripts/fuzz.sh [seconds] [build-dir]     (default 60 s, build-fuzz)
# A crash input is copied to fuzz/regressions/ (commit it: Scene.FuzzCorpusAndRegressionsReplay
# in tests/test_scene.cpp replays that folder in every test run) and the script fails.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
build_dir=${2:-build-fuzz}
scripts/install-packages.sh clang libclang-rt-14-dev libyaml-cpp-dev libeigen3-dev cmake ninja-build
CC=clang CXX=clang++ cmake -S fuzz -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build "$build_dir"

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/corpus" "$work/artifacts"
# Fixed seed: a CI run explores the same way each time (up to machine speed).
set +e
"$build_dir/scene_fuzzer" -seed=1 -max_total_time="$seconds" -max_len=4096 -timeout=10 -rss_limit_mb=2048 \
  -dict=fuzz/scene.dict -artifact_prefix="$work/artifacts/" -print_final_stats=1 \
  "$work/corpus" models tests/scenes fuzz/seeds fuzz/regressions 2>"$work/log"
status=$?
set -e
grep -E "^(#[0-9]+.*DONE|stat::number_of_executed_units|stat::new_units_added)" "$work/log" || true
if [ $status -ne 0 ]; then
  tail -60 "$work/log" >&2
  for f in "$work"/artifacts/*; do
    [ -e "$f" ] || continue
    cp "$f" fuzz/regressions/
    echo "fuzz.sh: crash input saved as fuzz/regressions/$(basename "$f")" >&2
  done
  exit 1
fi
echo "fuzz.sh: no crash in ${seconds} s"
