#!/usr/bin/env bash
# bondem against LIGGGHTS and LAMMPS on the peers' lattices: 20k = 20 800 spheres, 2 000 steps
# (cases/bench/peer_lattice.yaml, bench/peers/lattice.*) and 1m = 998 400 spheres, 200 steps
# (cases/bench/peer_lattice_1m.yaml, bench/peers/lattice_1m.*). Per lattice, first a physics check
# (kinetic energy and floor force at two steps, 1 core), then timings, codes alternating, REPS
# repetitions, medians. The physics runs count as the first 1-core repetition.
#
#   bench/compare_peers.sh [build_dir]
#     LATTICE=20k|1m|both   which lattices (default both)
#     CORES="1 2"           core counts: bondem threads, peer MPI ranks (default "1 2")
#     REPS=5                repetitions per code and core count (default 5)
#     PIN_CPU=0             run every code's one-core runs on this CPU (taskset; default: wherever
#                           the kernel puts them). On a virtual machine whose CPUs run at different
#                           speeds (measured here: one 25 % slower than the other for an hour),
#                           unpinned one-core times split into two groups by the CPU they landed on.
#     SECOND_CPU=1          with PIN_CPU: in every round also run bondem's one-core run on this CPU
#                           (code "bondem-second"), and report per round the two-core speed-up that
#                           a perfect split over the two CPUs would give, 1 + t(PIN_CPU) /
#                           t(SECOND_CPU), beside bondem's: on unequal vCPUs two threads cannot beat
#                           it, whatever the code. Each round also runs two one-core bondem runs at
#                           once, one on each CPU (codes "bondem-pair-first" and "bondem-pair-second",
#                           one output directory each), and reports the bound with both CPUs busy,
#                           t(PIN_CPU) (1 / t(pair first) + 1 / t(pair second)): what the host gives
#                           two cores working at the same moment, which a two-thread run needs.
#
# Per code and core count it reports the whole-process wall time (/usr/bin/time around the
# command: start-up, set-up, the steps and bondem's final output files), particle-steps/s from
# that wall time, the loop-only rate each code prints (the peers' "Loop time"; bondem's
# particle_steps_per_second, the steps and their output hooks), and the peak resident memory
# (GNU time's maximum resident set size; for an mpirun run, the sum of the ranks' peaks, each rank
# under its own /usr/bin/time, which bounds their simultaneous peak from above and leaves out
# mpirun itself). Results: output/compare_peers/summary.md (also printed), timings.csv, logs.
#
# Around every two-core run, $build/bench/bench_core_latency measures the one-way latency of a
# cache line between CPUs 0 and 1 (timings.csv's last two columns, before and after the run). On
# this virtual machine the host moves its two vCPUs between cores that share a level-3 cache
# (about 30 ns) and cores on different dies (170-260 ns) every few seconds to minutes; bondem's
# two threads, which share cache lines, run 1.1-1.35 times as long on different dies, two
# independent runs barely notice, and the peers' MPI ranks more in some stretches than in others
# (on 2026-12-07, within an hour of far placement, 1.15-1.77 times one core on the 20 800
# lattice). The rounds table reports each code's two cores over one for each placement apart.
#
# Needs `lmp`, `liggghts`, `mpirun` and GNU time (apt-get install --no-install-recommends lammps
# liggghts time: without --no-install-recommends apt also pulls python3-paraview, which removes
# libvtk9-dev).
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$repo/build/release}"
reps="${REPS:-5}"
read -r -a cores_list <<<"${CORES:-1 2}"
case "${LATTICE:-both}" in
  20k | 1m) lattices=("$LATTICE") ;;
  both) lattices=(20k 1m) ;;
  *) echo "compare_peers: LATTICE must be 20k, 1m or both, not '$LATTICE'" >&2; exit 2 ;;
esac
out="$repo/output/compare_peers"
codes=(bondem liggghts lammps)

[[ -z ${PIN_CPU:-} || $PIN_CPU =~ ^[0-9]+$ ]] || { echo "compare_peers: PIN_CPU must be a CPU number, not '$PIN_CPU'" >&2; exit 2; }
if [[ -n ${SECOND_CPU:-} ]]; then
  [[ $SECOND_CPU =~ ^[0-9]+$ ]] || { echo "compare_peers: SECOND_CPU must be a CPU number, not '$SECOND_CPU'" >&2; exit 2; }
  [[ -n ${PIN_CPU:-} ]] || { echo "compare_peers: SECOND_CPU needs PIN_CPU (the CPU it is compared with)" >&2; exit 2; }
  codes+=(bondem-second bondem-pair)
fi
# The pair's two runs are reported apart.
report_codes=()
for code in "${codes[@]}"; do
  if [[ $code == bondem-pair ]]; then report_codes+=(bondem-pair-first bondem-pair-second); else report_codes+=("$code"); fi
done
for tool in lmp liggghts mpirun /usr/bin/time taskset; do
  command -v "$tool" >/dev/null || { echo "compare_peers: '$tool' not found (see the header)" >&2; exit 2; }
done
[[ -x "$build/bondem" ]] || { echo "compare_peers: no $build/bondem; run scripts/build.sh" >&2; exit 2; }
build="$(cd "$build" && pwd)"  # the runs start in $out
mkdir -p "$out"
cp "$repo"/bench/peers/lattice.lammps "$repo"/bench/peers/lattice.liggghts \
  "$repo"/bench/peers/lattice_1m.lammps "$repo"/bench/peers/lattice_1m.liggghts "$out"/
cd "$out"

# Sets the lattice's case, peer inputs, size and the steps its physics check compares.
select_lattice() {
  case $1 in
    20k) case_file=peer_lattice.yaml peer_input=lattice particles=20800 steps=2000 check_steps=(500 2000) ;;
    1m) case_file=peer_lattice_1m.yaml peer_input=lattice_1m particles=998400 steps=200 check_steps=(100 200) ;;
  esac
  # Total weight of the lattice [N]: spheres of 1 mm radius at 2000 kg/m^3 under 9.81 m/s^2.
  weight=$(awk -v n="$particles" 'BEGIN { printf "%.10g", n * 2000 * 4 / 3 * 3.141592653589793e-9 * 9.81 }')
}

# One run of one code on `cores` cores; appends "lattice,code,cores,rep,wall_s,wall_rate,
# loop_rate,peak_kib,core_ns_before,core_ns_after" to timings.csv (the latencies of two-core runs
# only) and keeps its log as <lattice>.<code>.<cores>.log.
run_code() {
  local lattice=$1 code=$2 cores=$3 rep=$4 log="$out/$1.$2.$3.log" loop_rate
  local times="$out/$1.$2.$3.time" ranks="$out/$1.$2.$3.rss"
  local cmd
  case $code in
    bondem | bondem-second | bondem-pair-*) cmd=("$build/bondem" run "$repo/cases/bench/$case_file"
      --output "$out/$code.$lattice.$cores" --threads "$cores" --quiet) ;;
    lammps) cmd=(lmp -in "$peer_input.lammps" -log none) ;;
    liggghts) cmd=(liggghts -in "$peer_input.liggghts" -log none) ;;
  esac
  rm -f "$ranks"
  local before="" after=""
  [[ $cores -eq 2 ]] && before=$(core_latency)
  if [[ $code != bondem* && $cores -gt 1 ]]; then
    cmd=(mpirun --allow-run-as-root -np "$cores" /usr/bin/time -f %M -a -o "$ranks" "${cmd[@]}")
  fi
  if [[ -n ${PIN_CPU:-} && $cores -eq 1 ]]; then
    cmd=(taskset -c "$([[ $code == *-second ]] && echo "$SECOND_CPU" || echo "$PIN_CPU")" "${cmd[@]}")
  fi
  # The peers get one OpenMP thread per rank: their cores are MPI ranks.
  OMP_NUM_THREADS=$([[ $code == bondem* ]] && echo "$cores" || echo 1) \
    /usr/bin/time -f '%e %M' -o "$times" "${cmd[@]}" >"$log" 2>&1 ||
    { echo "compare_peers: $code failed on the $lattice lattice ($cores cores); see $log" >&2; exit 1; }
  [[ $cores -eq 2 ]] && after=$(core_latency)
  read -r wall peak <"$times"
  [[ -f $ranks ]] && peak=$(awk '{ s += $1 } END { print s }' "$ranks")
  if [[ $code == bondem* ]]; then
    loop_rate=$(awk -F' = ' '/^particle_steps_per_second/ { printf "%.0f", $2 }' "$log")
  else
    loop_rate=$(awk -v n="$particles" -v s="$steps" '/^Loop time of/ { printf "%.0f", n * s / $4; exit }' "$log")
  fi
  awk -v l="$lattice" -v k="$code" -v c="$cores" -v r="$rep" -v w="$wall" -v n="$particles" -v s="$steps" \
    -v lr="$loop_rate" -v p="$peak" -v b="$before" -v a="$after" \
    'BEGIN { printf "%s,%s,%d,%d,%.2f,%.0f,%s,%d,%s,%s\n", l, k, c, r, w, n * s / w, lr, p, b, a }' \
    >>"$out/timings.csv"
}

# Two one-core bondem runs at once, one on PIN_CPU and one on SECOND_CPU: rows bondem-pair-first
# and bondem-pair-second of repetition `rep`.
run_pair() {
  local lattice=$1 rep=$2 first second status=0
  run_code "$lattice" bondem-pair-first 1 "$rep" & first=$!
  run_code "$lattice" bondem-pair-second 1 "$rep" & second=$!
  # Both waited for, so that a failure leaves no run behind; run_code said why.
  wait "$first" || status=1
  wait "$second" || status=1
  [[ $status -eq 0 ]] || exit 1
}

# One entry of `codes` at one core count: bondem-second and the pair run on one core only.
run_entry() {
  local lattice=$1 code=$2 cores=$3 rep=$4
  case $code in
    bondem-pair) [[ $cores -ne 1 ]] || run_pair "$lattice" "$rep" ;;
    bondem-second) [[ $cores -ne 1 ]] || run_code "$lattice" "$code" "$cores" "$rep" ;;
    *) run_code "$lattice" "$code" "$cores" "$rep" ;;
  esac
}

# One-way latency [ns] of a cache line between CPUs 0 and 1 now; empty without the probe.
core_latency() {
  [[ -x $build/bench/bench_core_latency ]] || return 0
  "$build/bench/bench_core_latency" 0 1 | awk -F' = ' '{ print $2 }'
}

# Median of column `field` of timings.csv over one lattice, code and core count.
column_median() {
  local lattice=$1 code=$2 cores=$3 field=$4
  awk -F, -v l="$lattice" -v k="$code" -v c="$cores" -v f="$field" '$1 == l && $2 == k && $3 == c { print $f }' \
    "$out/timings.csv" | median
}

median() { sort -g | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }

# Kinetic energy [J] and floor force [N] of one code's 1-core run at one step: "ke force".
physics() {
  local lattice=$1 code=$2 step=$3
  if [[ $code == bondem ]]; then
    awk -F, -v t="$(awk -v s="$step" 'BEGIN { print s * 5e-7 }')" \
      'NR == 1 { for (c = 1; c <= NF; ++c) if ($c == "load_floor_z") col = c; next }
       ($1 - t < 1e-12 && t - $1 < 1e-12) { printf "%.6g %.6g\n", $2, -$col }' \
      "$out/bondem.$lattice.1/history.csv"
  else
    awk -v s="$step" -v w="$weight" \
      '$1 == s && NF == 5 { printf "%.6g %.6g\n", $3, $5 + w }' "$out/$lattice.$code.1.log"
  fi
}

# Runs every code once on 1 core (timings.csv rows of repetition 1) and compares their physics.
check_physics() {
  local lattice=$1 status=0 code step ke_b f_b ke f tolerance
  echo "== $lattice physics: kinetic energy [J] and floor force [N] at steps ${check_steps[*]} (1 core)"
  for code in "${codes[@]}"; do run_entry "$lattice" "$code" 1 1; done
  for step in "${check_steps[@]}"; do
    read -r ke_b f_b < <(physics "$lattice" bondem "$step")
    for code in liggghts lammps; do
      read -r ke f < <(physics "$lattice" $code "$step")
      # LIGGGHTS damps like bondem (restitution 0.5 through ln e); LAMMPS's `damping tsuji` uses
      # Tsuji's polynomial fit on (4/3) E* a, about 30 % less damping, hence the wider band.
      tolerance=$([[ $code == liggghts ]] && echo 0.02 || echo 0.10)
      awk -v c="$code" -v s="$step" -v kb="$ke_b" -v k="$ke" -v fb="$f_b" -v f="$f" -v tol="$tolerance" 'BEGIN {
        dk = (kb - k) / k; df = (f == 0 && fb == 0) ? 0 : (fb - f) / (f == 0 ? 1 : f)
        ok = (dk < tol && -dk < tol && df < tol && -df < tol)
        printf "step %4d  bondem KE %.5g F %.5g | %-8s KE %.5g F %.5g | differ %+.2f%% %+.2f%% (band %g%%) %s\n",
          s, kb, fb, c, k, f, 100 * dk, 100 * df, 100 * tol, ok ? "ok" : "DIFFERENT"
        exit ok ? 0 : 1 }' || status=1
    done
  done
  return $status
}

status=0
: >"$out/timings.csv"
for lattice in "${lattices[@]}"; do
  select_lattice "$lattice"
  if ! check_physics "$lattice"; then
    echo "compare_peers: $lattice physics differs; its speed not compared" >&2
    status=1
    continue
  fi
  echo "== $lattice speed: $reps repetitions, codes alternating, cores ${cores_list[*]}${PIN_CPU:+ (one-core runs on CPU $PIN_CPU)}"
  for cores in "${cores_list[@]}"; do
    first=$([[ $cores -eq 1 ]] && echo 2 || echo 1)  # the physics runs were 1-core repetition 1
    for ((r = first; r <= reps; ++r)); do
      for code in "${codes[@]}"; do run_entry "$lattice" "$code" "$cores" "$r"; done
    done
  done
done

# Medians per lattice, code and core count; bondem / x compares the whole-process rates.
{
  echo "| lattice | code | cores | runs | wall [s] | rate from wall [1/s] | loop rate [1/s] | peak RSS [MiB] | bondem / x |"
  echo "|---|---|---:|---:|---:|---:|---:|---:|---:|"
  for lattice in "${lattices[@]}"; do
    for cores in "${cores_list[@]}"; do
      b=$(column_median "$lattice" bondem "$cores" 6)
      [[ -n $b ]] || continue
      for code in "${report_codes[@]}"; do
        runs=$(awk -F, -v l="$lattice" -v k="$code" -v c="$cores" '$1 == l && $2 == k && $3 == c' "$out/timings.csv" | wc -l)
        [[ $runs -gt 0 ]] || continue  # bondem-second and the pair run on one core only
        awk -v l="$lattice" -v k="$code" -v c="$cores" -v n="$runs" \
          -v w="$(column_median "$lattice" "$code" "$cores" 5)" -v m="$(column_median "$lattice" "$code" "$cores" 6)" \
          -v lr="$(column_median "$lattice" "$code" "$cores" 7)" -v p="$(column_median "$lattice" "$code" "$cores" 8)" \
          -v b="$b" 'BEGIN {
          printf "| %s | %s | %d | %d | %.2f | %.3e | %.3e | %.0f | %.2f |\n", l, k, c, n, w, m, lr, p / 1024, b / m }'
      done
    done
  done
  # Ratios within each round (each code once, back to back): the host's drift, which moves the
  # codes' medians apart when it falls between their runs, moves a round's runs together.
  echo
  echo "| lattice | ratio | per round | median |"
  echo "|---|---|---|---:|"
  for lattice in "${lattices[@]}"; do
    awk -F, -v l="$lattice" -f "$repo/bench/compare_rounds.awk" "$out/timings.csv"
  done
} >"$out/summary.md"
cat "$out/summary.md"
echo "(medians; all runs: $out/timings.csv; these tables: $out/summary.md)"
exit $status
