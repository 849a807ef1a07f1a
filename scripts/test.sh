#!/usr/bin/env bash
# Sets up (packages, configure, build) and runs every test.
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${1:-build}
scripts/setup.sh "$build_dir"
ctest --test-dir "$build_dir" -j "${JOBS:-2}" --output-on-failure
