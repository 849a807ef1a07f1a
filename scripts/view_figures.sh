#!/usr/bin/env bash
# The README's screenshots of spacearm view (docs/figures/view_paper.png, view_space_arm7.png,
# view_ets_vii.png): the paper's plan and its p = 10 replay, space_arm7's plan and replay, and
# the published ETS-VII flying a line with its URDF visuals, each opened in
# Debian's Chromium at 60 % of the manoeuvre. Needs a build (scripts/setup.sh) and Chromium.
# Usage: scripts/view_figures.sh [OUT_DIR]   (default docs/figures; the pages go to out/view)
set -euo pipefail
cd "$(dirname "$0")/.."
figures=${1:-docs/figures}
scripts/install-packages.sh chromium
cli=build/cli/spacearm work=out/view
mkdir -p "$work" "$figures"
"$cli" plan models/paper_reference.yaml --from 1.5,0,0.5235987755982988 \
  --to 1.1,0,0.5235987755982988 --duration 10 -o "$work/paper_plan.csv"
"$cli" simulate models/paper_geared.yaml --plan "$work/paper_plan.csv" --param p=10 \
  -o "$work/paper_replay_p10.csv"
"$cli" view "$work/paper_replay_p10.csv" --compare "$work/paper_plan.csv" -o "$work/paper.html"
"$cli" plan models/space_arm7.yaml --q0 0,0,0,1,0,0,0,30,50,-20,-160,40,90,10 \
  --from 1.52,0.2012,1.2437 --to 1.62,0.12,1.14 --duration 4 -o "$work/arm7_plan.csv"
"$cli" simulate models/space_arm7.yaml --plan "$work/arm7_plan.csv" -o "$work/arm7_replay.csv"
"$cli" view "$work/arm7_replay.csv" --compare "$work/arm7_plan.csv" -o "$work/space_arm7.html"
"$cli" plan models/published/ets_vii.yaml --from 0.9,-0.3,2.0 --to 0.9,0.1,2.0 --duration 10 \
  --dt 0.05 -o "$work/ets_plan.csv"
"$cli" simulate models/published/ets_vii.yaml --plan "$work/ets_plan.csv" -o "$work/ets_fly.csv"
"$cli" view "$work/ets_fly.csv" -o "$work/ets_vii.html"
node web/test/screenshot.mjs build/web/node_modules "$work/paper.html" "$figures/view_paper.png" 6
node web/test/screenshot.mjs build/web/node_modules "$work/space_arm7.html" \
  "$figures/view_space_arm7.png" 2.4
node web/test/screenshot.mjs build/web/node_modules "$work/ets_vii.html" \
  "$figures/view_ets_vii.png" 5
echo "wrote $figures/view_paper.png, $figures/view_space_arm7.png, $figures/view_ets_vii.png" \
  "(pages in $work)"
