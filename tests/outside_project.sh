#!/usr/bin/env bash
# CTest: install spacearm into a temporary prefix, build examples/outside_project against it
# with find_package(spacearm), run it; edit its scene and check that the next build
# regenerates the model (and that a build without changes does not). The program plans on the
# rigid arm, replays into its flexible twin and closes a PD loop; its -Wall -Wextra build must
# print no warning (the installed headers and their Eigen and Boost are SYSTEM). About 80 s.
set -euo pipefail
build_dir=$1
source_dir=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cmake --install "$build_dir" --prefix "$work/prefix" >/dev/null
cp -r "$source_dir/examples/outside_project" "$work/project"
cmake -S "$work/project" -B "$work/build" -G Ninja -DCMAKE_PREFIX_PATH="$work/prefix" >/dev/null
cmake --build "$work/build" > "$work/log1"
# The installed headers are SYSTEM for the project: its -Wall -Wextra build has no warning.
if grep -q "warning:" "$work/log1"; then
  grep -c "warning:" "$work/log1"; grep -m5 "warning:" "$work/log1"; echo "FAIL: warnings"; exit 1
fi
grep -q "spacearm: generating model my_arm" "$work/log1" || { echo "FAIL: first build did not generate"; exit 1; }
first=$("$work/build/my_controller") || { echo "$first"; echo "FAIL: the program failed"; exit 1; }
echo "$first"
echo "$first" | grep -q "total mass 44 kg" || { echo "FAIL: unexpected output"; exit 1; }
echo "$first" | grep -q "dynamic-size model agrees" || { echo "FAIL: dynamic-size model"; exit 1; }
echo "$first" | grep -q "closed loop" || { echo "FAIL: no closed loop"; exit 1; }

cmake --build "$work/build" > "$work/log2"
if grep -q "generating model" "$work/log2"; then echo "FAIL: regenerated without a change"; exit 1; fi

sed -i 's/mass: 40.0/mass: 50.0/' "$work/project/my_arm.yaml" "$work/project/my_arm_flexible.yaml"
cmake --build "$work/build" > "$work/log3"
grep -q "spacearm: generating model my_arm" "$work/log3" || { echo "FAIL: edited scene not regenerated"; exit 1; }
second=$("$work/build/my_controller") || { echo "$second"; echo "FAIL: the edited arm's program failed"; exit 1; }
echo "$second"
echo "$second" | grep -q "total mass 54 kg" || { echo "FAIL: edit did not reach the program"; exit 1; }
echo "outside project: configured, built, ran, regenerated on edit"
