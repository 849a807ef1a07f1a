#!/usr/bin/env bash
# Sets up (packages, configure, build) and runs every test.
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${1:-build}
# clang-format: the style check (tests/format_check.sh) runs with the tests; Chromium: the
# browser test of spacearm view's pages (tests/view_browser.sh).
scripts/install-packages.sh clang-format chromium
scripts/setup.sh "$build_dir"
ctest --test-dir "$build_dir" -j "${JOBS:-2}" --output-on-failure
