#!/usr/bin/env bash
# The 3D experiment's figure from examples/spatial_experiment's table: the end effector's final
# position and orientation error against the gear ratio, exact rotors against armature, and the
# distance between the two (what the gyroscopic and rotor-momentum terms move).
# Usage: scripts/plot_spatial.sh OUT_DIR   (needs gnuplot)
set -euo pipefail
dir=${1:-out/spatial}
cd "$dir"
gnuplot <<'GP'
set terminal pngcairo size 1100,420 font "sans,11"
set datafile separator ","
set grid
set logscale xy
set format y "10^{%L}"
set key top left
set xlabel "gear ratio p"
set output "spatial_error_vs_ratio.png"
set multiplot layout 1,2 title "space\\_arm7: planned torques replayed into geared models (error against the replay without gears)"
set ylabel "final end-effector position error [m]"
plot "spatial_table.csv" using 1:2 with linespoints lw 2 pt 7 title "exact rotors", \
     "" using 1:4 with linespoints lw 2 pt 5 dt 2 title "armature", \
     "" using 1:6 with linespoints lw 1.5 pt 9 title "|exact - armature|"
set ylabel "final orientation error [rad]"
plot "spatial_table.csv" using 1:3 with linespoints lw 2 pt 7 title "exact rotors", \
     "" using 1:5 with linespoints lw 2 pt 5 dt 2 title "armature"
unset multiplot
GP
echo "wrote $dir/spatial_error_vs_ratio.png"
