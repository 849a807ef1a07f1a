#!/usr/bin/env bash
# Closed-loop study (examples/closed_loop): builds, runs, and draws the figures into
# out/closed_loop (override with OUT_DIR=...):
#   cl_ratios.png     tracking error and torques against the gear ratio, rigid geared plants
#   cl_stiffness.png  the same against the joint stiffness k, flexible plants (harmonic drive
#                     of size 20, k about 2.5e4 N m/rad, marked)
#   cl_torques.png    where the extra torque goes: applied minus planned torque over time
# Options pass through, e.g. scripts/closed_loop.sh --duration 2 --rate 2000
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh build >/dev/null
out="${OUT_DIR:-out/closed_loop}"
build/examples/closed_loop --out "$out" "$@"
cd "$out"
gnuplot <<'GP'
set terminal pngcairo size 1400,450 font "sans,10" noenhanced
set datafile separator ","
set grid
set key top left
set format y "%.0e"
do for [sweep in "ratios stiffness"] {
  file = "closed_loop_" . sweep . ".csv"
  set output (sweep eq "ratios" ? "cl_ratios.png" : "cl_stiffness.png")
  set multiplot layout 1, 3 title (sweep eq "ratios" ? "rigid geared plants: computed torque at 1 kHz built on the reference model or on the plant's own" : "flexible plants (p = 10, friction): computed torque built on the reference model or on the plant's own")
  set logscale x
  set logscale y
  set xlabel (sweep eq "ratios" ? "gear ratio p" : "joint stiffness k [N m/rad]")
  if (sweep eq "stiffness") { set arrow 1 from 2.5e4, graph 0 to 2.5e4, graph 1 nohead dt 2 lc rgb "gray" } else { unset arrow 1 }
  set ylabel "end-effector error [m]"
  set title "tracking error: max (solid) and at T (dashed)"
  plot for [c in "reference matching"] sprintf("< awk -F, '$2==\"%s\" && $11==0' %s", c, file) using 1:3 with linespoints lw 2 pt 7 title c." max", \
       for [c in "reference matching"] sprintf("< awk -F, '$2==\"%s\" && $11==0' %s", c, file) using 1:4 with linespoints lw 2 dt 2 pt 6 title c." at T"
  set ylabel "torque [N m]"
  set title "torque effort: RMS over joints and time (solid), peak (dashed)"
  plot for [c in "reference matching"] sprintf("< awk -F, '$2==\"%s\" && $11==0' %s", c, file) using 1:5 with linespoints lw 2 pt 7 title c." RMS", \
       for [c in "reference matching"] sprintf("< awk -F, '$2==\"%s\" && $11==0' %s", c, file) using 1:6 with linespoints lw 2 dt 2 pt 6 title c." peak"
  set title "extra torque beyond the plan's: RMS (solid), peak (dashed)"
  plot for [c in "reference matching"] sprintf("< awk -F, '$2==\"%s\" && $11==0' %s", c, file) using 1:7 with linespoints lw 2 pt 7 title c." RMS", \
       for [c in "reference matching"] sprintf("< awk -F, '$2==\"%s\" && $11==0' %s", c, file) using 1:8 with linespoints lw 2 dt 2 pt 6 title c." peak"
  unset multiplot
  unset logscale
}
unset arrow 1
set output "cl_torques.png"
set format y "%g"
set multiplot layout 1, 3 title "rigid geared plant at the series ratio: applied minus planned (reference-model, open-loop) torque"
do for [j = 1:3] {
  set title sprintf("joint %d", j)
  set xlabel "t [s]"
  set ylabel "tau - tau_plan [N m]"
  plot "closed_loop_torques.csv" using 1:(column(4 + j) - column(1 + j)) every ::1 with lines lw 2 title "controller on the reference model", \
       "" using 1:(column(7 + j) - column(1 + j)) every ::1 with lines lw 2 title "controller on the plant's model"
}
unset multiplot
GP
echo "figures: $out/cl_ratios.png cl_stiffness.png cl_torques.png"
