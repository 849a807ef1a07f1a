#!/usr/bin/env bash
# CTest: scripts/plot_sweep.sh draws any study: a small Monte Carlo (12 runs: a grid over p and
# I_m of the paper's geared model, a drawn link mass) gets a histogram per metric and a scatter
# figure per varying parameter, titled with the study's name; a grid over p and Im also gets Figures 9-10 with
# labelled contours. About 3 s. Usage: plot_sweep.sh SPACEARM SOURCE_DIR
set -euo pipefail
cli=$1 source_dir=$2
command -v gnuplot >/dev/null || { echo "gnuplot missing: skipped"; exit 77; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cat > "$work/little_study.yaml" <<YAML
scene: $source_dir/studies/paper_geared_uncertain.yaml
manoeuvre:
  plan: {from: [1.5, 0.0, 0.5235987755982988], to: [1.45, 0.02, 0.55], duration: 1}
integrator: {method: rk4, dt: 0.01}
grid:
  p: [1, 2, 4]
  Im: [1.0e-6, 1.0e-5]
random:
  runs: 2
  seed: 3
  draws:
    m3: {normal: [1.699, 0.1]}
YAML
"$cli" sweep "$work/little_study.yaml" -o "$work/out" --cache-dir "$work/cache" > "$work/sweep.log" 2>&1 ||
  { cat "$work/sweep.log"; echo "FAIL: the sweep"; exit 1; }
bash "$source_dir/scripts/plot_sweep.sh" "$work/out" "$work/little_study.yaml" > "$work/log" 2>&1
cat "$work/log"
for f in hist_ee_error hist_torque_rms scatter_p scatter_Im scatter_m3 fig9_sweep_ee_error fig10_sweep_ee_error_vs_p; do
  [[ $(head -c 4 "$work/out/$f.png" | tail -c 3) == PNG ]] || { echo "FAIL: no $f.png"; exit 1; }
done
grep -q "Contour" "$work/out/ee_error_contours.dat" || { echo "FAIL: no contour lines"; exit 1; }
if grep -q "little_study" "$work/out/ok_runs.dat"; then echo "FAIL: text in the data"; exit 1; fi
echo "plot_sweep: every figure drawn"
