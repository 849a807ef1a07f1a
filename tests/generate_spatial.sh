#!/usr/bin/env bash
# `spacearm generate` on a spatial scene (examples/spatial/arm7.yaml): it writes the header and
# source with the spatial layout (nq = nv + 1, the quaternion at 3), a second run with --check
# finds them up to date, and --plain is refused by name (a spatial arm has no closed forms).
#   tests/generate_spatial.sh SPACEARM SCENE
set -euo pipefail
spacearm=$1 scene=$2
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
"$spacearm" generate "$scene" -o "$out" | grep -q "(14 coordinates, 0 parameters)"
for fact in "inline constexpr int kNq = 14;" "inline constexpr int kNv = 13;" \
            "inline constexpr int kQuaternionOffset = 3;" "inline constexpr int kNumBase = 6;" \
            "inline constexpr bool kHas_forward_dynamics = true;" \
            "inline constexpr bool kHas_forward_dynamics_derivatives = false;"; do
  grep -qF "$fact" "$out/arm7.hpp" || { echo "missing in arm7.hpp: $fact" >&2; exit 1; }
done
"$spacearm" generate "$scene" -o "$out" --check | grep -q "up to date"
if "$spacearm" generate "$scene" -o "$out/plain" --plain 2>"$out/err"; then
  echo "--plain was accepted for a spatial scene" >&2; exit 1
fi
grep -q "has no closed forms" "$out/err"
echo "generate_spatial: ok"
