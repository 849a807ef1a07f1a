#!/usr/bin/env bash
# The main job: set up (packages, configure, build), run the paper's experiment (plan a
# straight line, replay the torques into geared models, Table 2) and draw Figures 3-8; then the
# paper's study as a sweep over p x I_m (studies/paper_gear_ratio.yaml) and its Figures 9-10;
# then the experiment in 3D (examples/spatial_experiment) and its figure; last, the pages of
# spacearm view: the manoeuvre (out/paper/view.html) and the study (out/paper/sweep/view.html).
# Usage: scripts/run-paper.sh [options of examples/paper_experiment, e.g. --elbow -1]
# Output folder: out/paper (override with OUT_DIR=...).
set -euo pipefail
cd "$(dirname "$0")/.."
# Only what it runs (the generator and the experiment; the tests are test.sh's), with progress.
SPACEARM_TARGETS="spacearm paper_experiment spatial_experiment" scripts/setup.sh build
out="${OUT_DIR:-out/paper}"
echo "== operation counts of the paper's generated models"
for scene in models/paper_reference.yaml models/paper_geared.yaml; do
  build/cli/spacearm generate "$scene" -o "$out/generated" --stats | grep -E "^(function|mass_matrix|bias)"
done
echo
build/examples/paper_experiment --out "$out" "$@"
scripts/plot_paper.sh "$out"
echo
echo "== the paper's study as a sweep: 37 gear ratios x 31 motor inertias (studies/paper_gear_ratio.yaml)"
rm -rf "$out/sweep"
build/cli/spacearm sweep studies/paper_gear_ratio.yaml -o "$out/sweep"
scripts/plot_sweep.sh "$out/sweep" studies/paper_gear_ratio.yaml
build/cli/spacearm view "$out/sweep/results.csv" -o "$out/sweep/view.html"
echo
echo "== the experiment in 3D: models/space_arm7, exact rotors against armature (examples/spatial_experiment)"
build/examples/spatial_experiment --out "$out/spatial"
scripts/plot_spatial.sh "$out/spatial"
echo
echo "== the manoeuvre in the browser: the plan (reference model) and its replay at p = 10 (geared)"
mkdir -p "$out/view"
build/cli/spacearm plan models/paper_reference.yaml --from 1.5,0,0.5235987755982988 \
  --to 1.1,0,0.5235987755982988 --duration 10 -o "$out/view/plan.csv"
build/cli/spacearm simulate models/paper_geared.yaml --plan "$out/view/plan.csv" --param p=10 \
  -o "$out/view/replay_p10.csv"
build/cli/spacearm view "$out/view/replay_p10.csv" --compare "$out/view/plan.csv" -o "$out/view.html"
echo "open $out/view.html and $out/sweep/view.html in a browser (no network needed)"
