#!/usr/bin/env bash
# The main job: set up, then derive and emit the paper's two models with operation counts,
# and show where the gear ratio enters the geared mass and Coriolis matrices.
# (The paper's simulation experiment, Table 2 and the figures come with the runtime.)
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${1:-build}
scripts/setup.sh "$build_dir" >/dev/null
spacearm="$build_dir/generator/spacearm"
out="${OUT_DIR:-out}/generated"
for scene in models/paper_reference.yaml models/paper_geared.yaml; do
  echo "== $scene"
  "$spacearm" generate "$scene" -o "$out" --stats
done
echo "== geared model, M[3][4] (qm1, qm2 entry):"
"$spacearm" inspect models/paper_geared.yaml 'M[3][4]' --decimal
echo "== geared model, C[0][3] in LaTeX:"
"$spacearm" inspect models/paper_geared.yaml 'C[0][3]' --latex --decimal
