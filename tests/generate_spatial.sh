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

# Issue 52: a tree whose end effectors' URDF links have hostile names. The header names them in
# kEndEffectorNames as octal escapes (no quote, backslash, newline or comment closer reaches the
# code) and compiles; the names read back from the compiled array are the URDF's.
mkdir -p "$out/tree"
cat > "$out/tree/tree.urdf" <<'URDF'
<robot name="t">
  <link name="sat"><inertial><mass value="100"/><inertia ixx="10" ixy="0" ixz="0" iyy="10" iyz="0" izz="10"/></inertial></link>
  <link name="a"><inertial><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>
  <link name="b"><inertial><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>
  <link name="x&quot;; */ \&#10;??/"/>
  <link name="y } #include"/>
  <joint name="ja" type="revolute"><parent link="sat"/><child link="a"/><origin xyz="0.5 0 0"/><axis xyz="0 0 1"/></joint>
  <joint name="jb" type="revolute"><parent link="sat"/><child link="b"/><origin xyz="-0.5 0 0"/><axis xyz="0 1 0"/></joint>
  <joint name="ta" type="fixed"><parent link="a"/><child link="x&quot;; */ \&#10;??/"/></joint>
  <joint name="tb" type="fixed"><parent link="b"/><child link="y } #include"/></joint>
</robot>
URDF
printf 'name: tree\nspace: spatial\nurdf: tree.urdf\nbase: {type: free_floating}\n' > "$out/tree/tree.yaml"
"$spacearm" generate "$out/tree/tree.yaml" -o "$out/tree" > /dev/null
grep -qF 'inline constexpr int kNumEndEffectors = 2;' "$out/tree/tree.hpp"
printf '#include "tree.hpp"\n#include <cstdio>\nint main() { for (const char* n : spacearm::models::tree::kEndEffectorNames) std::printf("[%%s]\\n", n); }\n' \
  > "$out/tree/names.cpp"
c++ -std=c++17 -I"$out/tree" $(pkg-config --cflags eigen3) "$out/tree/names.cpp" -o "$out/tree/names"
printf '[x"; */ \\\n??/]\n[y } #include]\n' > "$out/tree/want"
"$out/tree/names" | cmp - "$out/tree/want" || { echo "the names read back differ" >&2; exit 1; }
echo "generate_spatial: ok"
