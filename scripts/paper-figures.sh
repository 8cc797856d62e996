#!/usr/bin/env bash
# Reproduces the paper's Sec. 5 with bondem: Fig. 1 (overlap against time for four bond damping
# ratios), Fig. 2 (restitution against impact speed for nine densities) and the table of Fig. 3
# (simulated sticking threshold beside eq. 21 and the paper). Usage: paper-figures.sh OUTDIR
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-output/paper}"
bondem="${BONDEM:-build/release/bondem}"
mkdir -p "$out"

value_of() {  # value_of NAME < info output
  awk -v name="$1" '$1 == name && $2 == "=" { print $3; exit }'
}

# --- Fig. 1: example 5.1, impact at 2.6 m/s, xi_bond in {0.1, 0.25, 0.5, 1} -------------------
info=$("$bondem" info cases/paper_5_1.yaml)
delta_eq=$(value_of equilibrium_overlap <<<"$info")
delta_crit=$(value_of critical_overlap <<<"$info")
for xi in 0.1 0.25 0.5 1; do
  "$bondem" collide cases/paper_5_1.yaml --velocity 2.6 --set "bond.damping_ratio=$xi" \
    --trace "$out/fig1_xi_$xi.csv" --json >"$out/fig1_xi_$xi.json"
done
gnuplot <<EOF
set terminal pngcairo size 900,560 font ",11"
set output "$out/fig1_overlap.png"
set datafile separator ","
set title "Example 5.1: two spheres colliding at 2.6 m/s (α_{adh} = 1, ξ_{con} = 0)"
set xlabel "time [ms]"
set ylabel "overlap [um]"
set xrange [0:0.6]
set key right bottom
set grid
plot "$out/fig1_xi_0.1.csv" using (\$1*1e3):(\$2*1e6) every ::1 with lines lw 1.5 title "ξ_{bond} = 0.1", \
     "$out/fig1_xi_0.25.csv" using (\$1*1e3):(\$2*1e6) every ::1 with lines lw 1.5 title "ξ_{bond} = 0.25", \
     "$out/fig1_xi_0.5.csv" using (\$1*1e3):(\$2*1e6) every ::1 with lines lw 1.5 title "ξ_{bond} = 0.5", \
     "$out/fig1_xi_1.csv" using (\$1*1e3):(\$2*1e6) every ::1 with lines lw 1.5 title "ξ_{bond} = 1", \
     $delta_eq*1e6 with lines dt 2 lc rgb "black" title "δ_{eq}", \
     $delta_crit*1e6 with lines dt 3 lc rgb "red" title "δ_{crit}"
EOF

# --- Fig. 2 and the Fig. 3 table: example 5.2, xi_bond = 1, densities 500-8000 ----------------
densities=(500 1000 2000 3000 4000 5000 6000 7000 8000)
paper=(5.149 3.641 2.574 2.102 1.820 1.628 1.486 1.376 1.287)
table="$out/thresholds.md"
{
  echo "| density [kg/m³] | simulated threshold, ξ_con = 0 [m/s] | eq. (21) [m/s] | paper Fig. 3 [m/s] | simulated / eq. (21) − 1 | simulated threshold, ξ_con = 0.1 [m/s] |"
  echo "|---|---|---|---|---|---|"
} >"$table"
plot_lines=()
colors=("#1b9e77" "#d95f02" "#7570b3" "#e7298a" "#66a61e" "#e6ab02" "#a6761d" "#666666" "#000000")
for k in "${!densities[@]}"; do
  rho=${densities[$k]}
  set_density="materials.powder.density=$rho"
  "$bondem" collide cases/paper_5_2.yaml --set "$set_density" --sweep 0.5:6:111 \
    --out "$out/fig2_rho_$rho.csv"
  v_eq21=$("$bondem" info cases/paper_5_2.yaml --set "$set_density" | value_of critical_velocity)
  v_sim=$("$bondem" collide cases/paper_5_2.yaml --set "$set_density" --threshold 0.5:8 |
    value_of sticking_threshold)
  v_damped=$("$bondem" collide cases/paper_5_2.yaml --set "$set_density" \
    --set contact.damping_ratio=0.1 --threshold 0.5:12 | value_of sticking_threshold)
  awk -v rho="$rho" -v sim="$v_sim" -v eq="$v_eq21" -v paper="${paper[$k]}" -v damped="$v_damped" \
    'BEGIN { printf "| %d | %.4f | %.4f | %s | %+.2e | %.4f |\n", rho, sim, eq, paper, sim / eq - 1, damped }' \
    >>"$table"
  plot_lines+=("\"$out/fig2_rho_$rho.csv\" using 1:2 every ::1 with linespoints pt 7 ps 0.4 lc rgb \"${colors[$k]}\" title \"ρ = $rho\"")
done
plot_command=$(IFS=,; echo "${plot_lines[*]}")
gnuplot <<EOF
set terminal pngcairo size 900,560 font ",11"
set output "$out/fig2_restitution.png"
set datafile separator ","
set title "Example 5.2: restitution against impact speed (ξ_{bond} = 1, ξ_{con} = 0)"
set xlabel "impact speed [m/s]"
set ylabel "coefficient of restitution e"
set yrange [-0.05:1.1]
set key right center
set grid
plot $plot_command
EOF
cat "$table"
echo "paper-figures: wrote $out/fig1_overlap.png, $out/fig2_restitution.png, $table"
