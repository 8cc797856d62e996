#!/usr/bin/env bash
# Ranks x threads on this machine: `bondem run` of the peers' lattice (cases/bench/peer_lattice_1m,
# 998 400 spheres, 200 steps, and its first 4 layers, 102 400 spheres) on 1 process x 1 thread,
# 1 x 2 and 2 x 1 (strong scaling), and on 1 x 1 with half the lattice (weak scaling: 2 x 1 with
# the whole one keeps the particles per core). Every configuration runs REPS times (default 3),
# alternating; a row keeps the median of the run loop's wall time (bondem's wall_time: the steps
# and their outputs, not the setup) and the largest resident memory of one process, then checks
# that every run wrote the same final_state.csv as the first.
# Usage: bench/mpi_scaling.sh [OUT] [BUILD]   (defaults output/mpi_scaling, build/release);
# LATTICES="100k 1m half_100k half_1m" (default) chooses the rows; moving_100k and moving_1m are
# the lattices moving at 2.5 m/s along x (a list rebuild every 40 steps, 5 in the 200).
# Writes OUT/mpi_scaling.csv: lattice,particles,processes,threads,median_loop_s,
# particle_steps_per_s,total_wall_s,peak_rss_kb_per_process.
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-output/mpi_scaling}"
bondem="${2:-build/release}/bondem"
reps="${REPS:-3}"
mkdir -p "$out"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
case=cases/bench/peer_lattice_1m.yaml
steps=200

# One run: lattice processes threads [--set ...]; prints loop seconds, total seconds, peak KB.
run() {
  local lattice=$1 processes=$2 threads=$3
  shift 3
  local dir="$out/run_${lattice}_${processes}x${threads}"
  local case=$case
  [[ $lattice == moving_* ]] && case=$out/moving_lattice.yaml
  local launcher=()
  [ "$processes" -gt 0 ] && launcher=(mpirun --bind-to core -np "$processes")
  local start end
  start=$(date +%s.%N)
  /usr/bin/time -f "%M" -o "$out/rss" env OMP_NUM_THREADS="$threads" "${launcher[@]}" \
    "$bondem" run "$case" "$@" --output "$dir" --quiet >"$out/stdout"
  end=$(date +%s.%N)
  cmp -s "$dir/final_state.csv" "$out/reference_${lattice}.csv" 2>/dev/null ||
    { [ -f "$out/reference_${lattice}.csv" ] && { echo "final_state.csv of $dir differs" >&2; exit 1; }; \
      cp "$dir/final_state.csv" "$out/reference_${lattice}.csv"; }
  echo "$(awk '/^wall_time/ { print $3 }' "$out/stdout") $(echo "$end - $start" | bc) $(cat "$out/rss")"
}

median() { sort -g | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'; }

echo "lattice,particles,processes,threads,median_loop_s,particle_steps_per_s,total_wall_s,peak_rss_kb_per_process" \
  >"$out/mpi_scaling.csv"
# The lattice moving at 2.5 m/s (above the time step's limit for impacts at that speed, which
# a uniform motion never has: hence --unsafe-time-step).
sed 's/^    material: glass$/    material: glass\n    velocity: [2.5, 0.0, 0.0]/' "$case" \
  >"$out/moving_lattice.yaml"
for lattice in ${LATTICES:-100k 1m half_100k half_1m}; do
  case $lattice in
    moving_100k) sets=(--set insert.0.region.max.2=0.0075 --unsafe-time-step); particles=102400 ;;
    moving_1m) sets=(--unsafe-time-step); particles=998400 ;;
    100k) sets=(--set insert.0.region.max.2=0.0075); particles=102400 ;;
    1m) sets=(); particles=998400 ;;
    half_100k) sets=(--set insert.0.region.max.2=0.0075 --set insert.0.region.max.0=0.1589215
                     --set domain.max.0=0.15992); particles=51200 ;;
    half_1m) sets=(--set insert.0.region.max.0=0.1589215 --set domain.max.0=0.15992); particles=499200 ;;
  esac
  # 0 processes: without mpirun. The half lattices (weak scaling) run on one core only.
  configs="0x1 0x2 2x1"
  [[ $lattice == half_* ]] && configs="0x1"
  declare -A loops totals rss
  for rep in $(seq "$reps"); do
    for config in $configs; do
      read -r loop total kb < <(run "$lattice" "${config%x*}" "${config#*x}" "${sets[@]}")
      loops[$config]+="$loop "
      totals[$config]+="$total "
      rss[$config]=$(( ${rss[$config]:-0} > kb ? ${rss[$config]:-0} : kb ))
    done
  done
  for config in $configs; do
    loop=$(echo "${loops[$config]}" | tr ' ' '\n' | grep . | median)
    total=$(echo "${totals[$config]}" | tr ' ' '\n' | grep . | median)
    processes=${config%x*}
    echo "$lattice,$particles,$(( processes > 0 ? processes : 1 )),${config#*x},$loop,$(echo "$particles * $steps / $loop" | bc),$total,${rss[$config]}" \
      >>"$out/mpi_scaling.csv"
  done
  unset loops totals rss
done
cat "$out/mpi_scaling.csv"
