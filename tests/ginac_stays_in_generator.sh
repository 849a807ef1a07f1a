#!/usr/bin/env bash
# GiNaC stays inside the generator (issue 50): no header of jit/, runtime/, sweep/ or cli/ brings
# in a GiNaC header when preprocessed, and no source file outside generator/, tests/ and bench/
# includes a generator header that does. Cost: about 20 s (every header preprocessed once).
#   tests/ginac_stays_in_generator.sh CXX EIGEN_INCLUDE_DIR
set -euo pipefail
cd "$(dirname "$0")/.."
cxx=${1:?compiler} eigen=${2:?Eigen include dir}
generator_dirs=(generator generator/scene generator/program generator/derive generator/derive/planar
                generator/derive/spatial generator/lower generator/print)
includes=("${generator_dirs[@]/#/-I}" -Ijit -Iruntime -Isweep -Icli -Iexport -Ifiles -I"$eigen")
errors=$(mktemp)
trap 'rm -f "$errors"' EXIT
carries_ginac() {
  local text
  # Its diagnostics only where it fails (a header alone warns of its '#pragma once').
  text=$("$cxx" -std=c++20 -E "${includes[@]}" "$1" 2>"$errors") ||
    { cat "$errors" >&2; echo "ginac_stays_in_generator: cannot preprocess $1" >&2; exit 1; }
  grep -q '/ginac/' <<<"$text"
}

status=0
for h in jit/*.hpp runtime/*.hpp sweep/*.hpp cli/*.hpp export/*.hpp; do
  if carries_ginac "$h"; then echo "ginac_stays_in_generator: $h includes GiNaC" >&2; status=1; fi
done
# The generator's headers that carry GiNaC, and who outside it includes one.
ginac_headers=()
for h in $(find generator -name '*.hpp' | sort); do
  carries_ginac "$h" && ginac_headers+=("$(basename "$h")")
done
[[ ${#ginac_headers[@]} -gt 0 ]] || { echo "ginac_stays_in_generator: found no GiNaC header" >&2; exit 1; }
for h in "${ginac_headers[@]}"; do
  if users=$(grep -l "#include \"$h\"" jit/* runtime/* sweep/* cli/* python/*.cpp 2>/dev/null); then
    echo "ginac_stays_in_generator: $users include $h, which brings in GiNaC" >&2
    status=1
  fi
done
[[ $status == 0 ]] && echo "ginac_stays_in_generator: GiNaC is in ${#ginac_headers[@]} generator headers only"
exit $status
