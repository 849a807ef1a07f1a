#!/usr/bin/env bash
# Work-precision study of the paper's manoeuvre (examples/work_precision): builds, runs, and
# draws the figures into out/work_precision (override with OUT_DIR=...):
#   wp_evaluations.png  end-effector error vs right-hand-side evaluations, per gear ratio
#   wp_time.png         end-effector error vs wall time
#   wp_energy.png       energy-balance error vs evaluations
#   wp_precision.png    RK4 in float, double and long double vs step
#   wp_flexible.png     the stiff case (flexible joints, friction): error vs evaluations and
#                       vs wall time (failed runs, past an explicit method's stability, omitted)
# Options pass through, e.g. scripts/work_precision.sh --ratios 10 --repeats 5
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh build >/dev/null
out="${OUT_DIR:-out/work_precision}"
build/examples/work_precision --out "$out" "$@"
cd "$out"
ratios=$(tail -n +2 armature.csv | cut -d, -f1 | tr '\n' ' ')
gnuplot <<GP
set terminal pngcairo size 1400,450 font "sans,10" noenhanced
set datafile separator ","
set logscale xy
set grid
set format y "%.0e"
ratios = "$ratios"
methods = "rk4 implicit_midpoint dopri5 rkf78 dopri5+samples rkf78+samples"
set key top right
do for [col in "4 5"] {
  c = col + 0
  set output (c == 4 ? "wp_evaluations.png" : "wp_time.png")
  set multiplot layout 1, words(ratios)
  do for [i = 1:words(ratios)] {
    p = word(ratios, i)
    set title sprintf("p = %s", p)
    set xlabel (c == 4 ? "right-hand-side evaluations" : "wall time [s]")
    set ylabel "end-effector error at T [m]"
    plot for [m in methods] sprintf("< awk -F, '\$1==\"%s\" && \$2==\"%s\"' work_precision.csv", p, m) \
         using c:(\$6 > 0 ? \$6 : 1e-17) with linespoints lw 2 pt 7 title m
  }
  unset multiplot
}
set output "wp_energy.png"
set multiplot layout 1, words(ratios)
do for [i = 1:words(ratios)] {
  p = word(ratios, i)
  set title sprintf("p = %s", p)
  set xlabel "right-hand-side evaluations"
  set ylabel "|T(T) - T(0) - W| [J]"
  plot for [m in methods] sprintf("< awk -F, '\$1==\"%s\" && \$2==\"%s\"' work_precision.csv", p, m) \
       using 4:(\$8 > 0 ? \$8 : 1e-17) with linespoints lw 2 pt 7 title m
}
unset multiplot
set output "wp_precision.png"
set multiplot layout 1, words(ratios)
do for [i = 1:words(ratios)] {
  p = word(ratios, i)
  set title sprintf("RK4, p = %s", p)
  set xlabel "step [s]"
  set ylabel "end-effector error at T [m]"
  plot for [c = 3:5] sprintf("< awk -F, '\$1==\"%s\"' precision.csv", p) using 2:(column(c) > 0 ? column(c) : 1e-17) \
       with linespoints lw 2 pt 7 title (c == 3 ? "float" : c == 4 ? "double" : "long double")
}
unset multiplot
set output "wp_flexible.png"
set multiplot layout 1, 2 title "flexible joints with friction (stiff): end-effector error at T"
fmethods = "rk4 dopri5 rkf78 rosenbrock4 rosenbrock4+samples"
do for [c in "3 5"] {
  col = c + 0
  set title (col == 3 ? "against right-hand-side evaluations" : "against wall time")
  set xlabel (col == 3 ? "right-hand-side evaluations (rosenbrock4: plus one Jacobian per step)" : "wall time [s]")
  set ylabel "end-effector error at T [m]"
  plot for [m in fmethods] sprintf("< awk -F, '\$1==\"%s\" && \$6 != \"inf\"' flexible.csv", m) \
       using col:(\$6 > 0 ? \$6 : 1e-17) with linespoints lw 2 pt 7 title m
}
unset multiplot
GP
echo "figures: $out/wp_evaluations.png wp_time.png wp_energy.png wp_precision.png wp_flexible.png"
