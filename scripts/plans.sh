#!/usr/bin/env bash
# Plans that spare the satellite, beside today's straight line (issue 53): space_arm7 (geared,
# exact rotors) moves its tool 0.17 m in 4 s from rest to rest, planned four ways by
# `spacearm plan --objective`: line, reactionless (the same line, the base's angular velocity
# held at zero), min_base_rotation and min_effort (any path, IPOPT). Writes each plan's CSV, a
# table of base rotation, torques and planning time (plans.csv and plans.md), the base's
# rotation against time (plans_base_rotation.png, gnuplot) and the viewer's page of the
# least-rotation plan beside the line (view.html).
# Usage: scripts/plans.sh [OUT_DIR]   (default out/plans; builds spacearm first)
set -euo pipefail
cd "$(dirname "$0")/.."
SPACEARM_TARGETS="spacearm" scripts/setup.sh build
out=$(realpath -m "${1:-out/plans}")
mkdir -p "$out"
task=(models/space_arm7.yaml --q0 0,0,0,1,0,0,0,30,50,-20,-160,40,90,10
      --from 1.5199,0.20122,1.2437 --to 1.4199,0.30122,1.3437 --duration 4)
# First runs compile the scene, and the scene with its state Jacobian, into the cache (not
# timed below).
build/cli/spacearm plan "${task[@]}" -o "$out/warm-up.csv" 2>/dev/null
build/cli/spacearm plan "${task[@]}" --objective min_effort -o "$out/warm-up.csv" 2>/dev/null
for objective in line reactionless min_base_rotation min_effort; do
  echo "== plan --objective $objective"
  start=$(date +%s%N)
  build/cli/spacearm plan "${task[@]}" --objective "$objective" -o "$out/$objective.csv" \
    2> >(tee "$out/$objective.log" >&2)
  end=$(date +%s%N)
  echo "$(((end - start) / 1000000))" > "$out/$objective.ms"
done
# The table and the base's rotation angle per sample (Debian's Python: numpy).
/usr/bin/python3 - "$out" <<'PY'
import csv, sys
import numpy as np
out = sys.argv[1]
rows, series = [], {}
for objective in ["line", "reactionless", "min_base_rotation", "min_effort"]:
    with open(f"{out}/{objective}.csv") as f:
        r = list(csv.reader(f))
    head, data = r[0], np.array([[float(x) for x in row] for row in r[1:]])
    t = data[:, 0]
    quat = data[:, head.index("qw0"):head.index("qw0") + 4]
    start = quat[0] / np.linalg.norm(quat[0])
    dots = np.abs(quat @ start) / np.linalg.norm(quat, axis=1)
    angle = 2 * np.arccos(np.clip(dots, 0, 1))
    tau = data[:, head.index("tau1"):head.index("tau7") + 1]
    effort = np.sum(np.diff(t) * 0.5 * ((tau[:-1] ** 2).sum(1) + (tau[1:] ** 2).sum(1)))
    seconds = float(open(f"{out}/{objective}.ms").read()) / 1000
    rows.append([objective, angle.max(), angle[-1], np.abs(tau).max(), effort, seconds])
    series[objective] = (t, angle)
with open(f"{out}/plans.csv", "w") as f:
    f.write("objective,max_base_rotation,final_base_rotation,peak_tau,effort,seconds\n")
    for r in rows:
        f.write("%s,%.6e,%.6e,%.6e,%.6e,%.3f\n" % tuple(r))
with open(f"{out}/plans.md", "w") as f:
    f.write("| `--objective` | base rotation, max [rad] | at the end [rad] | peak abs(tau) [N m] "
            "| integral of tau^2 [N^2 m^2 s] | `plan` [s] |\n|---|---|---|---|---|---|\n")
    for r in rows:
        f.write("| %s | %.2e | %.2e | %.3g | %.3g | %.1f |\n" % tuple(r))
with open(f"{out}/plans_base_rotation.csv", "w") as f:
    f.write("t," + ",".join(series) + "\n")
    t = series["line"][0]
    for k in range(len(t)):
        f.write("%.4f," % t[k] + ",".join("%.6e" % max(series[o][1][k], 1e-20) for o in series) + "\n")
print(open(f"{out}/plans.md").read())
PY
cd "$out"
gnuplot <<'GP'
set terminal pngcairo size 900,420 font "sans,11"
set datafile separator ","
set grid
set logscale y
set format y "10^{%L}"
set yrange [1e-12:1]
set key bottom right
set xlabel "t [s]"
set ylabel "base rotation from its start [rad]"
set output "plans_base_rotation.png"
set title "space\\_arm7: the tool 0.17 m in 4 s, planned four ways (spacearm plan --objective)"
plot "plans_base_rotation.csv" using 1:2 with lines lw 2 title "line", \
     "" using 1:3 with lines lw 2 title "reactionless (planned: below 1e-12)", \
     "" using 1:4 with lines lw 2 title "min\\_base\\_rotation", \
     "" using 1:5 with lines lw 2 dt 2 title "min\\_effort"
GP
cd - >/dev/null
build/cli/spacearm view "$out/min_base_rotation.csv" --compare "$out/line.csv" -o "$out/view.html"
echo "wrote $out/plans.md, $out/plans_base_rotation.png and $out/view.html"
