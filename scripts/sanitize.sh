#!/usr/bin/env bash
# Builds everything with AddressSanitizer + UndefinedBehaviorSanitizer and runs the test
# suite under them (CI runs this after scripts/test.sh).
#   scripts/sanitize.sh [build-dir]     (default build-asan)
# -O1 -g1 keeps the build (about 15 minutes on 2 cores) and the run short with line numbers in
# reports. Leaks are checked; the one suppression is for libcln (GiNaC's number library),
# which keeps a few bytes reachable only through statics at exit.
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${1:-build-asan}
# Set before the build too: test discovery runs the test executables.
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=0:strict_string_checks=1
export LSAN_OPTIONS=suppressions=$PWD/scripts/lsan.supp:print_suppressions=0
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
# BOOST_UBLAS_NDEBUG, as in the Release build: uBLAS's debug checks compare an LU solve with a
# fixed tolerance and refuse a stiff spring's Jacobian (k = 1e12: rosenbrock4's first step) that
# the Release build solves; memory and undefined behaviour are what this build checks.
# The Python binding is not built: /usr/bin/python3 cannot load an instrumented module. Nor are
# the examples: thin drivers of the runtime (its tests run here), they are the build's four
# heaviest files (about 4 of its 24 CPU-minutes) and run as tests in scripts/test.sh.
scripts/setup.sh "$build_dir" -DSPACEARM_BUILD_PYTHON=OFF -DSPACEARM_BUILD_EXAMPLES=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1" \
  -DCMAKE_CXX_FLAGS="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer -DBOOST_UBLAS_NDEBUG"
# outside_project builds a separate install: nothing of it runs under the sanitizers.
ctest --test-dir "$build_dir" -j "${JOBS:-2}" --output-on-failure -E "^outside_project$"
