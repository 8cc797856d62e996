#!/usr/bin/env bash
# Picture of a laser track from a thermal run's final_state.csv: top view (x-y) of the layer,
# particles to scale and coloured by the peak temperature they reached, bonded particles ringed
# in black; below it, the peak temperature against the distance across the track.
# Usage: plot-laser-track.sh RUN_DIR OUT.png [TRACK_Y_MM] [BOND_TEMPERATURE_K]
set -euo pipefail
run="$1"
out="$2"
track_y="${3:-0.3}"
bond_t="${4:-1200}"
gnuplot <<GNUPLOT
set terminal pngcairo size 1200,900 font ",11" noenhanced
set output "$out"
set datafile separator ","
set multiplot layout 2,1 title "Laser track: peak temperature of each particle [K]; bonded particles ringed"
set palette defined (0 "#2c7bb6", 0.35 "#abd9e9", 0.6 "#ffffbf", 0.8 "#fdae61", 1 "#d7191c")
set cbrange [353:1900]
set xlabel "x, scan direction [mm]"
set ylabel "y [mm]"
set size ratio -1
set autoscale xfix
set autoscale yfix
plot "$run/final_state.csv" every ::1 using (\$2*1e3):(\$3*1e3):(\$8*1e3):(\$10) with circles lc palette fs solid 0.9 noborder notitle, \
     "$run/final_state.csv" every ::1 using (\$2*1e3):(\$11 > 0 ? \$3*1e3 : 1/0):(\$8*1e3) with circles lc rgb "black" lw 1.5 fs empty notitle
set size noratio
set xlabel "distance from the track axis [um]"
set ylabel "peak temperature [K]"
set xrange [-200:200]
unset colorbox
plot "$run/final_state.csv" every ::1 using ((\$3*1e3 - $track_y)*1e3):(\$10):(\$10) with points pt 7 ps 0.5 lc palette notitle, \
     $bond_t with lines dt 2 lc rgb "black" title "bonding temperature"
unset multiplot
GNUPLOT
echo "plot-laser-track: wrote $out"
