#!/usr/bin/env bash
# CTest: generating the same scene in two separate processes gives byte-identical files.
set -euo pipefail
spacearm=$1
scene=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for run in a b; do
  mkdir -p "$work/$run"
  (cd "$work/$run" && "$spacearm" generate "$scene" -o out >/dev/null)
done
cmp "$work/a/out/"*.hpp "$work/b/out/"*.hpp
cmp "$work/a/out/"*.cpp "$work/b/out/"*.cpp
echo "identical: $(ls "$work/a/out")"
