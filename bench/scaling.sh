#!/usr/bin/env bash
# Strong and weak scaling of whole steps, 10^3 to 10^6 particles, 1 to all threads, with and
# without friction; writes OUT/scaling.csv and OUT/scaling.png. Usage: bench/scaling.sh [OUT]
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-output/scaling}"
mkdir -p "$out"
bin=build/release/bench/bench_scaling
if [ "${PLOT_ONLY:-0}" != 1 ]; then  # PLOT_ONLY=1 redraws the PNG from an existing CSV
{
  echo "model,$($bin --steps 1 --sizes 1000 | head -1)"
  $bin --steps 100 --sizes 1000,10000,100000,1000000 | tail -n +2 | sed 's/^/frictionless,/'
  $bin --friction --steps 100 --sizes 1000,10000,100000,1000000 | tail -n +2 | sed 's/^/friction,/'
} >"$out/scaling.csv"
fi
cat "$out/scaling.csv"
threads=$(nproc)
gnuplot <<GNUPLOT
set terminal pngcairo size 900,560 font ",11"
set output "$out/scaling.png"
set datafile separator ","
set logscale x
set xlabel "particles"
set ylabel "particle-steps per second (millions)"
set key left top
set grid
plot for [t=1:$threads] "< grep '^frictionless,' $out/scaling.csv | awk -F, '\$3==" . t . "'" using 2:(\$4/1e6) with linespoints title sprintf("frictionless, %d thread(s)", t), \
     for [t=1:$threads] "< grep '^friction,' $out/scaling.csv | awk -F, '\$3==" . t . "'" using 2:(\$4/1e6) with linespoints dt 2 title sprintf("mu = 0.5, %d thread(s)", t)
GNUPLOT
echo "scaling: wrote $out/scaling.csv and $out/scaling.png"
