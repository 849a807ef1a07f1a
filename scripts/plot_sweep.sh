#!/usr/bin/env bash
# The figure the paper did not have: final end-effector error of the open-loop replay against
# the gear ratio p and the motor inertia I_m, from the results.csv of
# `spacearm sweep studies/paper_gear_ratio.yaml` (columns run,status,p,Im,...,ee_error,...).
# Usage: scripts/plot_sweep.sh RESULTS_DIR   (needs gnuplot)
set -euo pipefail
dir=${1:?usage: scripts/plot_sweep.sh RESULTS_DIR}
cd "$dir"
header=$(head -1 results.csv)
[[ $header == run,status,p,Im,*ee_error* ]] || {
  echo "plot_sweep: $dir/results.csv is not a p x Im study (header: $header)" >&2; exit 1; }
col=$(tr ',' '\n' <<<"$header" | grep -nx ee_error | cut -d: -f1)
if grep -q '^[0-9]*,failed,' results.csv; then
  echo "plot_sweep: $(grep -c '^[0-9]*,failed,' results.csv) runs failed; they are left out" >&2
fi
# Scan lines of the grid (a blank line when p changes), as gnuplot's pm3d reads them.
awk -F, -v c="$col" 'NR > 1 && $2 == "ok" { if (NR > 2 && $3 != p) print ""; p = $3;
  print $3, $4, $c }' results.csv > ee_error_grid.dat
# Every 6th motor inertia, one block per I_m (p ascending), for the lines of fig. 10.
awk 'NF == 3' ee_error_grid.dat | sort -g -k2,2 -k1,1 |
  awk '{ if ($2 != last) { n++; last = $2; if ((n - 1) % 6 == 0) printf "%s\n\n", (n > 1 ? "\n" : "") }
         if ((n - 1) % 6 == 0) print }' > ee_error_by_Im.dat
inertias=$(awk 'NF == 3 && $2 != last { last = $2; print $2 }' ee_error_by_Im.dat | tr '\n' ' ')
gnuplot <<GP
set terminal pngcairo size 900,650 font "sans,11"
set output "fig9_sweep_ee_error.png"
set title "Final end-effector error of the open-loop replay (torques tau/p of the p = 1 plan)"
set xlabel "gear ratio p"; set ylabel "motor inertia I_m [kg m^2]"
set logscale y; set format y "10^{%L}"; set autoscale fix
set cblabel "log_{10} |end-effector error| [m]"
set view map; set pm3d map interpolate 0,0
set contour base; set cntrparam levels incremental -6,1,0; unset clabel
splot "ee_error_grid.dat" using 1:2:(log10(\$3)) with pm3d notitle, \\
      "" using 1:2:(log10(\$3)) nosurface with lines lc rgb "white" notitle

set output "fig10_sweep_ee_error_vs_p.png"
unset view; unset pm3d; unset contour; set grid; unset logscale; set logscale y
set format y "10^{%L}"
set title "Final end-effector error against p, one line per motor inertia"
set xlabel "gear ratio p"; set ylabel "|end-effector error| [m]"; set key outside right
inertias = "$inertias"
plot for [i=1:words(inertias)] "ee_error_by_Im.dat" index i-1 using 1:3 with linespoints \\
     pt 7 ps 0.5 title sprintf("I_m = %.2g kg m^2", real(word(inertias, i)))
GP
echo "wrote $dir/fig9_sweep_ee_error.png fig10_sweep_ee_error_vs_p.png"
