#!/usr/bin/env bash
# Installs CppAD and CppADCodeGen, which Pinocchio's generated ABA derivatives need
# (pinocchio_peer.hpp: build_codegen; neither is packaged in Debian 12), from their public
# repositories: CppAD's small library (cppad_lib) and headers, CppADCodeGen's headers (its
# configure step writes two of them; its tests' googletest comes from Debian's googletest
# sources, not the network). About 10 s on 2 cores.
# Usage: bench/peers/cppadcg.sh [PREFIX]   (default /opt/cppadcg; CppAD 20240000.7, CppADCodeGen
#   v2.5.0), then add -DPINOCCHIO_CPPADCG_DIR=PREFIX to the Pinocchio bench build's cmake
#   (bench/peers/pinocchio.sh). The peer generates and compiles the derivatives when
#   bench_spatial starts (about 9 s per model, gcc -Ofast as Pinocchio's own default).
# Needs the network (git clone); as root it installs what it builds with first.
set -euo pipefail
prefix=$(realpath -m "${1:-/opt/cppadcg}")
if [ "$(id -u)" = 0 ]; then
  apt-get update
  apt-get install -y git cmake ninja-build g++ googletest
fi
src=$(mktemp -d)
trap 'rm -rf "$src"' EXIT
git clone --depth 1 --branch 20240000.7 https://github.com/coin-or/CppAD "$src/cppad"
git clone --depth 1 --branch v2.5.0 https://github.com/joaoleal/CppADCodeGen "$src/cppadcg"
cmake -S "$src/cppad" -B "$src/cppad/build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -Dcppad_prefix="$prefix" -DCMAKE_INSTALL_PREFIX="$prefix" -Dinclude_eigen=false
cmake --build "$src/cppad/build" -j "$(nproc)" --target install
cmake -S "$src/cppadcg" -B "$src/cppadcg/build" -G Ninja -DCMAKE_INSTALL_PREFIX="$prefix" \
  -DCPPAD_HOME="$prefix" -DFETCHCONTENT_SOURCE_DIR_GOOGLETEST=/usr/src/googletest
cmake --build "$src/cppadcg/build" --target install
echo "CppAD and CppADCodeGen installed in $prefix: pass -DPINOCCHIO_CPPADCG_DIR=$prefix with" \
  "-DPINOCCHIO_DIR to the bench's cmake"
