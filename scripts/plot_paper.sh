#!/usr/bin/env bash
# Figures like the paper's Figures 3-8 from the CSV files of examples/paper_experiment.
# Usage: scripts/plot_paper.sh OUT_DIR   (needs gnuplot)
set -euo pipefail
dir=${1:-out/paper}
cd "$dir"
ratios=$(tail -n +2 table2.csv | cut -d, -f1 | tr '\n' ' ')
gnuplot <<GP
set terminal pngcairo size 900,650 font "sans,11"
set datafile separator ","
set grid
set key outside right
# Nine distinct colours (one per default gear ratio), then repeat.
set linetype 9 lc rgb "#8b4513"
set linetype cycle 9
ratios = "$ratios"

set output "fig3_path.png"
set title "Fig. 3: planned end-effector line and arm configurations (reference model)"
set xlabel "x [m]"; set ylabel "y [m]"; set size ratio -1
set key below
set datafile separator " "
plot for [i=0:5] "arm_plan.dat" index i using 1:2 with linespoints lw 1.5 pt 7 ps 0.7 \
       title sprintf("arm at t = %.0f%% of T", 20*i), \
     "< tail -n +2 replay_p1.csv | tr ',' ' '" using 2:3 with lines lw 3 lc rgb "red" title "end-effector path"
set datafile separator ","
set size noratio
set key outside right

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
set title "Fig. 6: final arm configurations"
set xlabel "x [m]"; set ylabel "y [m]"; set size ratio -1
set key below
set datafile separator " "
plot for [i=0:words(ratios)-1] "arm_final.dat" index i using 1:2 with linespoints lw 2 pt 7 ps 0.6 \
     title sprintf("p = %s", word(ratios, i+1))
set datafile separator ","
set size noratio
set key outside right

set output "fig7_joint_velocities.png"
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
GP
echo "wrote $dir/fig3_path.png fig4_torques.png fig5_paths.png fig6_final_configurations.png fig7_joint_velocities.png fig8_base.png"
