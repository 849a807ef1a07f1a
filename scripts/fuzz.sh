#!/usr/bin/env bash
# Builds the fuzzers (clang, libFuzzer + ASan + UBSan) and runs each for a bounded time:
#   scene_fuzzer  scene parsing and validation, on the seed corpus (shipped scenes, test
#                 scenes, fuzz/seeds, fuzz/regressions), for [seconds];
#   text_fuzzer   torque CSV reader, CLI number lists, comment escaping of emitted files
#                 (fuzz/text_seeds, fuzz/text_regressions), for half of that;
#   study_fuzzer  study files and the torque files they name (fuzz/study_seeds,
#                 fuzz/study_regressions), for half of that;
#   view_fuzzer   spacearm view's run CSVs and provenance records (fuzz/view_seeds,
#                 fuzz/view_regressions), for half of that.
#   scripts/fuzz.sh [seconds] [build-dir]     (default 60 s, build-fuzz)
# A crash input is copied to the fuzzer's regressions folder (commit it: the replay tests
# Scene.FuzzCorpusAndRegressionsReplay, TorqueCsv.FuzzSeedsAndRegressionsReplay and
# Study.FuzzSeedsAndRegressionsReplay run those
# folders in every test run) and the script fails.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
build_dir=${2:-build-fuzz}
scripts/install-packages.sh clang libclang-rt-14-dev libyaml-cpp-dev libeigen3-dev libboost-dev libtinyxml2-dev nlohmann-json3-dev pkg-config cmake ninja-build
CC=clang CXX=clang++ cmake -S fuzz -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build "$build_dir"

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# run_fuzzer NAME SECONDS REGRESSIONS_DIR [libFuzzer options and corpus folders...]
run_fuzzer() {
  local name=$1 time=$2 regressions=$3
  shift 3
  mkdir -p "$work/$name/corpus" "$work/$name/artifacts"
  # Fixed seed: a CI run explores the same way each time (up to machine speed).
  set +e
  # New inputs go to the first corpus folder: the scratch one, never a folder of the repository.
  "$build_dir/$name" -seed=1 -max_total_time="$time" -max_len=4096 -timeout=10 -rss_limit_mb=2048 \
    -artifact_prefix="$work/$name/artifacts/" -print_final_stats=1 "$@" 2>"$work/$name/log"
  local status=$?
  set -e
  echo "$name:"
  grep -E "^(#[0-9]+.*DONE|stat::number_of_executed_units|stat::new_units_added)" "$work/$name/log" || true
  if [ $status -ne 0 ]; then
    tail -60 "$work/$name/log" >&2
    for f in "$work/$name"/artifacts/*; do
      [ -e "$f" ] || continue
      cp "$f" "$regressions/"
      echo "fuzz.sh: crash input saved as $regressions/$(basename "$f")" >&2
    done
    exit 1
  fi
  echo "fuzz.sh: $name: no crash in ${time} s"
}

mkdir -p "$work/scene_fuzzer/corpus" "$work/text_fuzzer/corpus" "$work/study_fuzzer/corpus" \
  "$work/view_fuzzer/corpus"
run_fuzzer scene_fuzzer "$seconds" fuzz/regressions -dict=fuzz/scene.dict \
  "$work/scene_fuzzer/corpus" models tests/scenes fuzz/seeds fuzz/regressions
run_fuzzer text_fuzzer "$((seconds / 2))" fuzz/text_regressions \
  "$work/text_fuzzer/corpus" fuzz/text_seeds fuzz/text_regressions
run_fuzzer study_fuzzer "$((seconds / 2))" fuzz/study_regressions -dict=fuzz/study.dict \
  "$work/study_fuzzer/corpus" fuzz/study_seeds fuzz/study_regressions
run_fuzzer view_fuzzer "$((seconds / 2))" fuzz/view_regressions \
  "$work/view_fuzzer/corpus" fuzz/view_seeds fuzz/view_regressions
