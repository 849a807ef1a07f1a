#!/usr/bin/env bash
# Builds the Pinocchio peer of bench_spatial (pinocchio_peer.hpp) from its public repository:
# Pinocchio is not packaged in Debian 12. The core is header-only here (no template
# instantiation, no Python); its parsers are the one compiled library (the peer reads the MJCF
# that spacearm exports; Pinocchio's MJCF parser includes its URDF one, hence urdfdom). About
# 30 s on 2 cores.
# Usage: bench/peers/pinocchio.sh [PREFIX] [TAG]   (default /opt/pinocchio, v3.7.0)
#   then: scripts/setup.sh build-bench-pinocchio -DSPACEARM_BUILD_BENCH=ON -DSPACEARM_BENCH_QUICK=ON \
#           -DSPACEARM_BUILD_TESTS=OFF -DCMAKE_CXX_FLAGS=-march=native -DPINOCCHIO_DIR=PREFIX
# Its generated derivatives' row also needs CppAD and CppADCodeGen: bench/peers/cppadcg.sh.
# Needs the network (git clone); as root it installs Boost's libraries first.
set -euo pipefail
prefix=$(realpath -m "${1:-/opt/pinocchio}")
tag=${2:-v3.7.0}
if [ "$(id -u)" = 0 ]; then
  apt-get update
  apt-get install -y git cmake ninja-build g++ libeigen3-dev libboost-filesystem-dev \
    libboost-serialization-dev libboost-system-dev liburdfdom-dev
fi
src=$(mktemp -d)
trap 'rm -rf "$src"' EXIT
git clone --depth 1 --branch "$tag" --recursive https://github.com/stack-of-tasks/pinocchio "$src"
# -march=native as the peer's source (bench/CMakeLists.txt): Eigen's alignment must match across
# Pinocchio's library and the peer, and it is Pinocchio's recommended build for speed.
cmake -S "$src" -B "$src/build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS=-march=native \
  -DCMAKE_INSTALL_PREFIX="$prefix" \
  -DBUILD_PYTHON_INTERFACE=OFF -DBUILD_TESTING=OFF \
  -DBUILD_WITH_COLLISION_SUPPORT=OFF -DENABLE_TEMPLATE_INSTANTIATION=OFF
cmake --build "$src/build" -j "$(nproc)" --target install
echo "Pinocchio $tag installed in $prefix: pass -DPINOCCHIO_DIR=$prefix and" \
  "-DCMAKE_CXX_FLAGS=-march=native to the bench's cmake"
