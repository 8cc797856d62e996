#!/usr/bin/env bash
# Picture of a spread layer from a run's final_state.csv: side view (x-z) and top view (x-y),
# particles drawn to scale and coloured by height. Usage: plot-spreading.sh RUN_DIR OUT.png
set -euo pipefail
run="$1"
out="$2"
gnuplot <<GNUPLOT
set terminal pngcairo size 1200,700 font ",11"
set output "$out"
set datafile separator ","
set multiplot layout 2,1 title "Spread layer (final state): side view and top view, colour = height [um]"
set palette defined (0 "#2c7bb6", 0.5 "#ffffbf", 1 "#d7191c")
set cbrange [0:400]
set xlabel "x, spreading direction [mm]"
set ylabel "z [mm]"
set xrange [0:${XMAX:-6}]
set size ratio 0.2
plot "$run/final_state.csv" every ::1 using (\$2*1e3):(\$4*1e3):(\$8*1e3):(\$4*1e6) with circles lc palette fs solid 0.9 noborder notitle
set ylabel "y [mm]"
set size ratio -1
plot "$run/final_state.csv" every ::1 using (\$2*1e3):(\$3*1e3):(\$8*1e3):(\$4*1e6) with circles lc palette fs solid 0.9 noborder notitle
unset multiplot
GNUPLOT
echo "plot-spreading: wrote $out"
