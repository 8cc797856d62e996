#!/usr/bin/env bash
# bondem against LIGGGHTS and LAMMPS on the peers' lattice (cases/bench/peer_lattice.yaml and
# bench/peers/lattice.*): first a physics check (kinetic energy and floor force at steps 500 and
# 2000), then timings at 1 and 2 cores, codes alternating, REPS repetitions, medians.
#
#   bench/compare_peers.sh [build_dir]        REPS=5 by default; results in output/compare_peers/
#
# Needs `lmp` and `liggghts` (apt-get install --no-install-recommends lammps liggghts: without
# --no-install-recommends apt also pulls python3-paraview, which removes libvtk9-dev).
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$repo/build/release}"
reps="${REPS:-5}"
out="$repo/output/compare_peers"
particles=20800
steps=2000
# Total weight of the lattice [N]: 20 800 spheres of 1 mm radius at 2000 kg/m^3 under 9.81 m/s^2.
weight=$(awk -v n=$particles 'BEGIN { printf "%.10g", n * 2000 * 4 / 3 * 3.141592653589793e-9 * 9.81 }')

for tool in lmp liggghts mpirun; do
  command -v "$tool" >/dev/null || { echo "compare_peers: '$tool' not found (see the header)" >&2; exit 2; }
done
[[ -x "$build/bondem" ]] || { echo "compare_peers: no $build/bondem; run scripts/build.sh" >&2; exit 2; }
mkdir -p "$out"
cp "$repo"/bench/peers/lattice.lammps "$repo"/bench/peers/lattice.liggghts "$out"/
cd "$out"

# One run of one code on `cores` cores; prints particle-steps per second, keeps its log.
run_code() {
  local code=$1 cores=$2 log="$out/$1.$2.log" loop
  case $code in
    bondem)
      OMP_NUM_THREADS=$cores "$build/bondem" run "$repo/cases/bench/peer_lattice.yaml" \
        --output "$out/bondem.$cores" --threads "$cores" --quiet >"$log"
      awk -F' = ' '/^particle_steps_per_second/ { printf "%.0f\n", $2 }' "$log"
      return ;;
    lammps) local cmd=(lmp -in lattice.lammps -log none) ;;
    liggghts) local cmd=(liggghts -in lattice.liggghts -log none) ;;
  esac
  if [[ $cores -gt 1 ]]; then
    cmd=(mpirun --allow-run-as-root -np "$cores" "${cmd[@]}")
  fi
  OMP_NUM_THREADS=1 "${cmd[@]}" >"$log" 2>&1
  loop=$(awk '/^Loop time of/ { print $4; exit }' "$log")
  awk -v t="$loop" -v n=$particles -v s=$steps 'BEGIN { printf "%.0f\n", n * s / t }'
}

median() { sort -g | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }

echo "== physics: kinetic energy [J] and floor force [N] at steps 500 and 2000 (1 core)"
for code in bondem lammps liggghts; do run_code $code 1 >/dev/null; done
physics() {  # code step -> "ke force"
  local code=$1 step=$2
  if [[ $code == bondem ]]; then
    awk -F, -v t="$(awk -v s="$step" 'BEGIN { print s * 5e-7 }')" \
      'NR == 1 { for (c = 1; c <= NF; ++c) if ($c == "load_floor_z") col = c; next }
       ($1 - t < 1e-12 && t - $1 < 1e-12) { printf "%.6g %.6g\n", $2, -$col }' \
      "$out/bondem.1/history.csv"
  else
    awk -v s="$step" -v w="$weight" \
      '$1 == s && NF == 5 { printf "%.6g %.6g\n", $3, $5 + w }' "$out/$code.1.log"
  fi
}
status=0
for step in 500 2000; do
  read -r ke_b f_b < <(physics bondem $step)
  for code in liggghts lammps; do
    read -r ke f < <(physics $code $step)
    # LIGGGHTS damps like bondem (restitution 0.5 through ln e); LAMMPS's `damping tsuji` uses
    # Tsuji's polynomial fit on (4/3) E* a, about 30 % less damping, hence the wider band.
    tolerance=$([[ $code == liggghts ]] && echo 0.02 || echo 0.10)
    awk -v c=$code -v s=$step -v kb="$ke_b" -v k="$ke" -v fb="$f_b" -v f="$f" -v tol="$tolerance" 'BEGIN {
      dk = (kb - k) / k; df = (f == 0 && fb == 0) ? 0 : (fb - f) / (f == 0 ? 1 : f)
      ok = (dk < tol && -dk < tol && df < tol && -df < tol)
      printf "step %4d  bondem KE %.5g F %.5g | %-8s KE %.5g F %.5g | differ %+.2f%% %+.2f%% (band %g%%) %s\n",
        s, kb, fb, c, k, f, 100 * dk, 100 * df, 100 * tol, ok ? "ok" : "DIFFERENT"
      exit ok ? 0 : 1 }' || status=1
  done
done
[[ $status -eq 0 ]] || { echo "compare_peers: physics differs; speed not compared" >&2; exit 1; }

echo "== speed: $reps repetitions, codes alternating, particle-steps per second"
: >"$out/timings.csv"
for cores in 1 2; do
  for ((r = 1; r <= reps; ++r)); do
    for code in bondem liggghts lammps; do
      echo "$code,$cores,$(run_code $code "$cores")" >>"$out/timings.csv"
    done
  done
done
printf '%-9s %6s %16s %10s\n' code cores "median [1/s]" "bondem/x"
for cores in 1 2; do
  b=$(awk -F, -v c=$cores '$1 == "bondem" && $2 == c { print $3 }' "$out/timings.csv" | median)
  for code in bondem liggghts lammps; do
    m=$(awk -F, -v k=$code -v c=$cores '$1 == k && $2 == c { print $3 }' "$out/timings.csv" | median)
    awk -v k=$code -v c=$cores -v m="$m" -v b="$b" 'BEGIN { printf "%-9s %6d %16.3e %10.2f\n", k, c, m, b / m }'
  done
done
echo "(all timings: $out/timings.csv)"
