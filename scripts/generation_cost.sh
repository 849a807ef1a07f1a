#!/usr/bin/env bash
# Generation cost against N: derive and emit time (spacearm generate --stats), compile time
# (g++ -O2, as CompiledModel and spacearm_add_model compile), M + bias and forward dynamics
# operation counts with the formulation the generator chose,
# source and object size, for the benchmark chains (bench/scenes). Markdown table on stdout.
#   scripts/generation_cost.sh [build-dir]     (default build; needs the generator built)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
spacearm="$build/cli/spacearm"
eigen=$(pkg-config --cflags eigen3 2>/dev/null || echo -I/usr/include/eigen3)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
echo "| scene | n | derive [s] | emit [s] | compile [s] | M+bias ops | M+bias form | FD ops | FD form | sin/cos | source [kB] | object [kB] |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
for n in 2 3 4 6 8 10 12 16 20 30; do
  for kind in "" _geared; do
    scene=chain_n$n$kind
    stats=$("$spacearm" generate "bench/scenes/$scene.yaml" -o "$work" --stats)
    derive=$(echo "$stats" | sed -n 's/^derive \([0-9]*\) ms, emit \([0-9]*\) ms$/\1/p')
    emit=$(echo "$stats" | sed -n 's/^derive \([0-9]*\) ms, emit \([0-9]*\) ms$/\2/p')
    # Columns of --stats: function basis adds muls divs total sin/cos tanh/exp formulation...
    mb=$(echo "$stats" | awk '$1 == "mass_matrix_and_bias" {f = $9; for (i = 10; i <= NF; i++) f = f " " $i; print $6 "|" $7 "|" f}')
    fd=$(echo "$stats" | awk '$1 == "forward_dynamics" {f = $9; for (i = 10; i <= NF; i++) f = f " " $i; print $6 "|" f}')
    start=$EPOCHREALTIME
    g++ -std=c++17 -O2 $eigen -c "$work/$scene.cpp" -o "$work/$scene.o"
    compile=$(awk -v a="$start" -v b="$EPOCHREALTIME" 'BEGIN {print b - a}')
    src=$(( $(stat -c %s "$work/$scene.cpp") / 1024 ))
    obj=$(( $(stat -c %s "$work/$scene.o") / 1024 ))
    printf "| %s | %d | %.2f | %.2f | %.1f | %s | %s | %s | %s | %s | %d | %d |\n" "$scene" "$((n + 3))" \
      "$(awk -v x="$derive" 'BEGIN {print x / 1000}')" "$(awk -v x="$emit" 'BEGIN {print x / 1000}')" "$compile" \
      "$(echo "$mb" | cut -d'|' -f1)" "$(echo "$mb" | cut -d'|' -f3)" "$(echo "$fd" | cut -d'|' -f1)" \
      "$(echo "$fd" | cut -d'|' -f2)" "$(echo "$mb" | cut -d'|' -f2)" "$src" "$obj"
  done
done
