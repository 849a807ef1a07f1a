#!/usr/bin/env bash
# Figures of any study's results.csv (`spacearm sweep STUDY -o RESULTS_DIR`), titled from the
# study file when it is given:
#   - for every metric (ee_error, base_drift, ..., torque_rms): its histogram over the runs,
#     hist_METRIC.png;
#   - for every parameter that varies over the runs: each metric against it, scatter_PARAM.png
#     (one panel per metric);
#   - for a grid over p and Im (the paper's study, studies/paper_gear_ratio.yaml) also the
#     map of the end-effector error (fig9) and its lines against p (fig10), contours labelled.
# Failed runs are left out and counted. Usage: scripts/plot_sweep.sh RESULTS_DIR [STUDY_FILE]
# (needs gnuplot)
set -euo pipefail
usage="usage: scripts/plot_sweep.sh RESULTS_DIR [STUDY_FILE]: figures of a sweep's results.csv, written into RESULTS_DIR (hist_*.png, scatter_*.png; fig9/fig10 for a p x Im grid)"
[[ ${1:-} == -h || ${1:-} == --help ]] && { echo "$usage"; exit 0; }
dir=${1:?$usage}
study=${2:-}
name=$(basename "${study:-$dir}")
[[ -f $dir/results.csv ]] || { echo "plot_sweep: no $dir/results.csv" >&2; exit 1; }
cd "$dir"
header=$(head -1 results.csv)
IFS=, read -r -a names <<<"$header"
# The columns: run, status, the parameters, the metrics (ee_x ... torque_rms), command_ratio,
# message.
first_metric=0; last_metric=0
for i in "${!names[@]}"; do
  [[ ${names[$i]} == ee_x ]] && first_metric=$i
  [[ ${names[$i]} == torque_rms ]] && last_metric=$i
done
(( first_metric > 2 && last_metric > first_metric )) || {
  echo "plot_sweep: $dir/results.csv is not a spacearm sweep's (header: $header)" >&2; exit 1; }
ratio=$(awk -F, -v c=$((last_metric + 2)) 'NR == 2 { print $c }' results.csv)
failed=$(grep -c '^[0-9]*,failed,' results.csv || true)
(( failed == 0 )) || echo "plot_sweep: $failed runs failed; they are left out" >&2
# The ok rows as whitespace-separated numbers (gnuplot reads them without the message).
awk -F, -v last=$((last_metric + 1)) 'NR > 1 && $2 == "ok" {
  line = ""; for (i = 3; i <= last; ++i) line = line (i > 3 ? " " : "") $i; print line }' \
  results.csv > ok_runs.dat
runs=$(wc -l < ok_runs.dat)
(( runs > 0 )) || { echo "plot_sweep: no run succeeded" >&2; exit 1; }
metrics=("${names[@]:first_metric:last_metric - first_metric + 1}")
params=()
for ((c = 2; c < first_metric; ++c)); do
  # A parameter varies if its ok runs hold more than one value.
  distinct=$(awk -v c=$((c - 1)) '{ print $c }' ok_runs.dat | sort -u | head -2 | wc -l)
  (( distinct > 1 )) && params+=("$c:${names[$c]}")
done
units() {
  case $1 in
    ee_x|ee_y|ee_z|ee_error|base_drift) echo "[m]" ;;
    ee_phi|ee_angle_error|base_rotation) echo "[rad]" ;;
    torque_rms) echo "[N m]" ;; momentum_drift) echo "[N s, N m s]" ;; *) echo "" ;;
  esac
}
plots=""
for m in "${metrics[@]}"; do
  for i in "${!names[@]}"; do [[ ${names[$i]} == "$m" ]] && col=$((i - 1)); done
  plots+="
set output 'hist_$m.png'
set title '$name: $m over $runs runs (command_ratio $ratio)' noenhanced
set xlabel '$m $(units "$m")' noenhanced; set ylabel 'runs'
stats 'ok_runs.dat' using $col nooutput
w = (STATS_max > STATS_min) ? (STATS_max - STATS_min) / 30 : 1
bin(x) = w * floor((x - STATS_min) / w) + STATS_min + w / 2
plot 'ok_runs.dat' using (bin(\$$col)):(1.0) smooth frequency with boxes fs solid 0.6 notitle
"
done
for pc in "${params[@]}"; do
  c=${pc%%:*}; p=${pc#*:}
  n=${#metrics[@]}; rows=$(( (n + 2) / 3 ))
  plots+="
set output 'scatter_$p.png'
set terminal pngcairo size 1350,$((380 * rows)) font 'sans,10'
set multiplot layout $rows,3 title '$name: every metric against $p ($runs runs, command_ratio $ratio)' noenhanced
set xtics rotate by -30
"
  for m in "${metrics[@]}"; do
    for i in "${!names[@]}"; do [[ ${names[$i]} == "$m" ]] && col=$((i - 1)); done
    plots+="set title '$m' noenhanced; set xlabel '$p' noenhanced; set ylabel '$(units "$m")'
plot 'ok_runs.dat' using $((c - 1)):$col with points pt 7 ps 0.4 notitle
"
  done
  plots+="unset multiplot
set xtics norotate
set terminal pngcairo size 900,650 font 'sans,11'
"
done
# (A metric that is the same in every run draws a flat line: gnuplot's warning about its empty
# range says nothing new.)
gnuplot 2> >(grep -v "empty [xy] range" >&2) <<GP
set terminal pngcairo size 900,650 font "sans,11"
set grid
$plots
GP
echo "plot_sweep: wrote ${#metrics[@]} histograms and ${#params[@]} scatter figures into $dir"

# The paper's study: a grid over p and Im.
[[ $header == run,status,p,Im,*ee_error* ]] || exit 0
col=$(tr ',' '\n' <<<"$header" | grep -nx ee_error | cut -d: -f1)
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
# The contour lines as data first (gnuplot cannot tabulate them in pm3d's map mode, and the
# table takes the axes' formats: before those are set).
set contour base; set cntrparam levels incremental -6,1,0; unset surface
set table "ee_error_contours.dat"
splot "ee_error_grid.dat" using 1:2:(log10(\$3))
unset table
set surface; unset contour
set output "fig9_sweep_ee_error.png"
set title "$name: final end-effector error of the open-loop replay (command_ratio $ratio)" noenhanced
set xlabel "gear ratio p"; set ylabel "motor inertia I_m [kg m^2]"
set logscale y; set format y "10^{%L}"; set autoscale fix
set cblabel "log_{10} |end-effector error| [m]"
set view map; set pm3d map interpolate 0,0
# Each contour line labelled with its level (log10 of the error) near its middle.
splot "ee_error_grid.dat" using 1:2:(log10(\$3)) with pm3d notitle, \\
      "ee_error_contours.dat" using 1:2:3 with lines lc rgb "white" notitle, \\
      "ee_error_contours.dat" using 1:2:3:(sprintf("%.0f", \$3)) every 25 with labels \\
        tc rgb "white" font ",9" notitle

set output "fig10_sweep_ee_error_vs_p.png"
unset view; unset pm3d; set grid; unset logscale; set logscale y
set format y "10^{%L}"
set title "$name: final end-effector error against p, one line per motor inertia" noenhanced
set xlabel "gear ratio p"; set ylabel "|end-effector error| [m]"; set key outside right
inertias = "$inertias"
plot for [i=1:words(inertias)] "ee_error_by_Im.dat" index i-1 using 1:3 with linespoints \\
     pt 7 ps 0.5 title sprintf("I_m = %.2g kg m^2", real(word(inertias, i)))
GP
echo "plot_sweep: wrote $dir/fig9_sweep_ee_error.png fig10_sweep_ee_error_vs_p.png"
