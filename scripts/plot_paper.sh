#!/usr/bin/env bash
# Figures like the paper's Figures 3-8 from the CSV files of examples/paper_experiment.
# Usage: scripts/plot_paper.sh OUT_DIR   (needs gnuplot)
set -euo pipefail
dir=${1:-out/paper}
cd "$dir"
ratios=$(tail -n +2 table2.csv | cut -d, -f1 | tr '\n' ' ')
# The end effectors' extent in arm_final.dat (the last point of each arm), padded.
read -r ee_xmin ee_xmax ee_ymin ee_ymax ee_pad < <(awk '
  NF == 2 && $1 !~ /#/ { x = $1; y = $2; have = 1 }
  NF != 2 && have { take(); have = 0 }
  END { if (have) take(); span = (X - x0 > Y - y0 ? X - x0 : Y - y0);
        pad = (span > 0 ? span * 0.3 : 1e-4); if (pad < 2e-5) pad = 2e-5;
        print x0, X, y0, Y, pad }
  function take() { if (n++ == 0) { x0 = X = x; y0 = Y = y }
    if (x < x0) x0 = x; if (x > X) X = x; if (y < y0) y0 = y; if (y > Y) Y = y }' arm_final.dat)
gnuplot <<GP
set terminal pngcairo size 900,650 font "sans,11"
set datafile separator ","
set grid
set key outside right
# Nine distinct colours (one per default gear ratio), then repeat.
set linetype 9 lc rgb "#8b4513"
set linetype cycle 9
ratios = "$ratios"
ee_xmin = $ee_xmin; ee_xmax = $ee_xmax; ee_ymin = $ee_ymin; ee_ymax = $ee_ymax; ee_pad = $ee_pad

set output "fig3_path.png"
# The arm spans about 1.5 m by 0.5 m: a wide picture, the key beside it (not below, which left
# most of the figure white).
set terminal pngcairo size 1100,380 font "sans,11"
set title "Fig. 3: planned end-effector line and arm configurations (reference model)"
set xlabel "x [m]"; set ylabel "y [m]"; set size ratio -1
set key outside right vertical
set datafile separator " "
plot for [i=0:5] "arm_plan.dat" index i using 1:2 with linespoints lw 1.5 pt 7 ps 0.7 \
       title sprintf("arm at t = %.0f%% of T", 20*i), \
     "< tail -n +2 replay_p1.csv | tr ',' ' '" using 2:3 with lines lw 3 lc rgb "red" title "end-effector path"
set datafile separator ","
set size noratio
set key outside right
set terminal pngcairo size 900,650 font "sans,11"

set output "fig4_torques.png"
set title "Fig. 4: planned joint torques (eq. 5, reference model)"
set xlabel "t [s]"; set ylabel "torque [N m]"
plot "plan.csv" using 1:8 with lines lw 2 title "tau1", "" using 1:9 with lines lw 2 title "tau2", \
     "" using 1:10 with lines lw 2 title "tau3"

set output "fig5_paths.png"
set title "Fig. 5: end-effector paths for the gear ratios (torques tau/p replayed)"
set xlabel "x [m]"; set ylabel "y [m]"
plot for [p in ratios] sprintf("replay_p%s.csv", p) using 2:3 with lines lw 2 title sprintf("p = %s", p)

set output "fig6_final_configurations.png"
# The final arms differ by millimetres at most: drawn whole they are one arm, so the right panel
# magnifies the region around the end effectors (the last point of each arm).
set terminal pngcairo size 1200,560 font "sans,11"
set datafile separator " "
stats "arm_final.dat" using 1 nooutput
set multiplot layout 1,2 title "Fig. 6: final arm configurations"
set title "whole arms"; set xlabel "x [m]"; set ylabel "y [m]"; set size ratio -1
unset key
plot for [i=0:words(ratios)-1] "arm_final.dat" index i using 1:2 with linespoints lw 2 pt 7 ps 0.6 \
     title sprintf("p = %s", word(ratios, i+1))
set size noratio
set key outside right vertical
set title sprintf("around the end effectors: x %.4f .. %.4f m, y %.4f .. %.4f m", ee_xmin, ee_xmax, ee_ymin, ee_ymax)
set xrange [ee_xmin - ee_pad : ee_xmax + ee_pad]; set yrange [ee_ymin - ee_pad : ee_ymax + ee_pad]
set format x "%.4f"; set format y "%.4f"; set xtics rotate by -30
plot for [i=0:words(ratios)-1] "arm_final.dat" index i using 1:2 with linespoints lw 2 pt 7 ps 1.2 \
     title sprintf("p = %s", word(ratios, i+1))
unset multiplot
set autoscale; set format x "% h"; set format y "% h"; set xtics norotate
set datafile separator ","
set key outside right
set terminal pngcairo size 900,650 font "sans,11"

set output "fig7_joint_velocities.png"
# The same plot area in every panel (the first one's key must not narrow it): fixed margins.
set lmargin at screen 0.10; set rmargin at screen 0.80
set multiplot layout 3,1 title "Fig. 7: joint (link-side) velocities"
unset title
set key outside right top vertical
do for [j=1:3] {
  if (j > 1) { unset key }
  set ylabel sprintf("qd%d [rad/s]", j)
  set xlabel (j == 3 ? "t [s]" : "")
  plot for [p in ratios] sprintf("replay_p%s.csv", p) using 1:(column(7+j)) with lines lw 1.5 title sprintf("p = %s", p)
}
unset multiplot

set output "fig8_base.png"
set multiplot layout 3,1 title "Fig. 8: base position and orientation"
names = "x0 y0 q0"
units = "m m rad"
set key outside right top vertical
do for [j=1:3] {
  if (j > 1) { unset key }
  set ylabel sprintf("%s [%s]", word(names, j), word(units, j))
  set xlabel (j == 3 ? "t [s]" : "")
  plot for [p in ratios] sprintf("replay_p%s.csv", p) using 1:(column(4+j)) with lines lw 1.5 title sprintf("p = %s", p)
}
unset multiplot
unset lmargin; unset rmargin
GP
echo "wrote $dir/fig3_path.png fig4_torques.png fig5_paths.png fig6_final_configurations.png fig7_joint_velocities.png fig8_base.png"
