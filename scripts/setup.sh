#!/usr/bin/env bash
# Installs what spacearm needs (Debian packages, only those missing), configures and builds.
# Usage: scripts/setup.sh [BUILD_DIR [CMAKE_ARGS...]]   (default: build, Release)
# SPACEARM_TARGETS="a b": build only those targets (the main job builds what it runs).
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${1:-build}
shift || true

packages=(g++ cmake ninja-build pkg-config libginac-dev coinor-libipopt-dev libeigen3-dev libyaml-cpp-dev libcli11-dev libtinyxml2-dev
          libgtest-dev libboost-dev gnuplot-nox nlohmann-json3-dev libmujoco-dev
          libssl-dev pybind11-dev python3-dev python3-numpy python3-pytest python3-distributed
          python3-venv python3-pip)
# Node.js and npm bundle the viewer's script (web/); a machine may have them from elsewhere.
command -v node >/dev/null || packages+=(nodejs)
command -v npm >/dev/null || packages+=(npm)
scripts/install-packages.sh "${packages[@]}"

cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
targets=()
for t in ${SPACEARM_TARGETS:-}; do targets+=(--target "$t"); done
cmake --build "$build_dir" -j "${JOBS:-2}" "${targets[@]}"
