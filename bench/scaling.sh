#!/usr/bin/env bash
# Strong and weak scaling of whole steps on a dense lattice, with and without friction.
# Usage: bench/scaling.sh [OUT] [BUILD]   (defaults output/scaling, build/release)
# Writes OUT/strong.csv (10^3..10^6 particles x 1..all threads), OUT/weak.csv (a fixed number of
# particles per thread) and OUT/scaling.png. Every row runs in its own process, so the peak
# resident memory it reports per particle is that configuration's alone.
# REPS (default 3) processes per row, median rate; STEPS (default 100) the timed steps per row, SIZES the strong-scaling sizes, WEAK_SIZE the
# particles per thread (default 500000); PARTS="strong weak" (default) or one of them reruns only
# that table; PLOT_ONLY=1 redraws the PNG from the CSVs.
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-output/scaling}"
bin="${2:-build/release}/bench/bench_scaling"
steps="${STEPS:-100}"
threads=$(nproc)
mkdir -p "$out"

reps="${REPS:-3}"

# One process: model,particles,threads,particle_steps_per_second,peak_bytes_per_particle.
run() {  # model size threads
  local flag=""
  [ "$1" = friction ] && flag="--friction"
  $bin $flag --steps "$steps" --sizes "$2" --threads "$3" | tail -1 |
    awk -F, -v model="$1" '{ print model "," $1 "," $2 "," $3 "," $6 }'
}

# This machine's speed drifts between runs: every configuration runs REPS times, the thread
# counts alternating, and a row keeps the median rate and the largest memory.
sweep() {  # model size... (sizes are per thread when WEAK=1)
  local model=$1 size t r
  shift
  for size in "$@"; do
    for ((r = 0; r < reps; ++r)); do
      for t in $(seq 1 "$threads"); do
        run "$model" $((WEAK ? size * t : size)) "$t"
      done
    done
  done
}
median_rows() {
  sort -t, -k1,1 -k2,2n -k3,3n -k4,4g | awk -F, 'BEGIN { OFS = "," }
    function flush() { if (count) print key, (count % 2) ? rate[(count + 1) / 2] : (rate[count / 2] + rate[count / 2 + 1]) / 2, memory }
    { k = $1 "," $2 "," $3
      if (k != key) { flush(); key = k; count = 0; memory = 0 }
      rate[++count] = $4; if ($5 > memory) memory = $5 }
    END { flush() }'
}
header="model,particles,threads,particle_steps_per_second,peak_bytes_per_particle"

parts="${PARTS:-strong weak}"
if [ "${PLOT_ONLY:-0}" != 1 ] && [[ $parts == *strong* ]]; then
  {
    echo "$header"
    for model in frictionless friction; do
      WEAK=0 sweep "$model" ${SIZES:-1000 10000 100000 1000000}
    done | median_rows
  } | awk -F, 'BEGIN { OFS = "," }
      NR == 1 { print $0, "speedup", "efficiency"; next }
      { rows[NR] = $0; k[NR] = $1 "," $2; t[NR] = $3; r[NR] = $4; if ($3 == 1) single[k[NR]] = $4 }
      END { for (i = 2; i <= NR; ++i) printf "%s,%.3f,%.3f\n", rows[i], r[i] / single[k[i]], r[i] / single[k[i]] / t[i] }' \
    >"$out/strong.csv"
fi
if [ "${PLOT_ONLY:-0}" != 1 ] && [[ $parts == *weak* ]]; then
  # Weak scaling: WEAK_SIZE particles per thread; efficiency = rate(T) / (T rate(1)).
  {
    echo "$header"
    for model in frictionless friction; do WEAK=1 sweep "$model" "${WEAK_SIZE:-500000}"; done |
      median_rows
  } | awk -F, 'BEGIN { OFS = "," }
      NR == 1 { print $0, "weak_efficiency"; next }
      { if ($3 == 1) single[$1] = $4; printf "%s,%.3f\n", $0, $4 / single[$1] / $3 }' >"$out/weak.csv"
fi
echo "strong scaling:"
column -s, -t "$out/strong.csv"
echo "weak scaling:"
column -s, -t "$out/weak.csv"
gnuplot <<GNUPLOT
set terminal pngcairo size 900,560 font ",11"
set output "$out/scaling.png"
set datafile separator ","
set logscale x
set xlabel "particles"
set ylabel "particle-steps per second (millions)"
set key left top
set grid
plot for [t=1:$threads] "< grep '^frictionless,' $out/strong.csv | awk -F, '\$3==" . t . "'" using 2:(\$4/1e6) with linespoints title sprintf("frictionless, %d thread(s)", t), \
     for [t=1:$threads] "< grep '^friction,' $out/strong.csv | awk -F, '\$3==" . t . "'" using 2:(\$4/1e6) with linespoints dt 2 title sprintf("mu = 0.5, %d thread(s)", t)
GNUPLOT
echo "scaling: wrote $out/strong.csv, $out/weak.csv and $out/scaling.png"
