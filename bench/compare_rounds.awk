# Per round of compare_peers.sh's timings.csv (lattice,code,cores,rep,wall,...), for lattice l:
# bondem's wall time against the faster peer's of the same round at each core count, and bondem's
# one core against its two cores, each as the list of rounds and its median. A round runs every
# code once, back to back, so its ratios share the host's state of the moment. Each code's two
# cores over one is also given per placement of the two vCPUs, from the core-to-core latency
# probed before and after its two-core run (columns 9 and 10): both under kFarNs, CPUs sharing a
# cache; both above, CPUs on different dies; a run with one of each is in neither.
BEGIN { kFarNs = 100 }
function median_of(v, n,    i, j, t) {
  for (i = 2; i <= n; ++i) for (j = i; j > 1 && v[j - 1] > v[j]; --j) { t = v[j]; v[j] = v[j - 1]; v[j - 1] = t }
  return n % 2 ? v[(n + 1) / 2] : (v[n / 2] + v[n / 2 + 1]) / 2
}
# Prints code k's one core over two cores per round and their median, over the rounds whose
# two-core run had placement `kind` ("" for every round), as the row `title`.
function two_over_one(k, kind, title,    r, n, text, v) {
  n = 0; text = ""
  for (r = 1; r <= rounds; ++r) {
    if (kind != "" && (!((k SUBSEP r) in placement) || placement[k, r] != kind)) continue
    if (!((1 SUBSEP r SUBSEP k) in wall) || !((2 SUBSEP r SUBSEP k) in wall)) continue
    v[++n] = wall[1, r, k] / wall[2, r, k]
    text = text (n > 1 ? ", " : "") sprintf("%.2f", v[n])
  }
  if (n > 0) printf "| %s | %s | %s | %.2f |\n", l, title, text, median_of(v, n)
}
# Per round, what a split over two CPUs whose one-core runs took t(a) and t(b) would give against
# bondem's one-core run, t(bondem) (1 / t(a) + 1 / t(b)), as the row `title`, and bondem's two
# cores over one against it as the row `against`.
function bound_rows(a, b, title, against,    r, n, m, text, fraction_text, v, f) {
  n = 0; m = 0; text = ""; fraction_text = ""
  for (r = 1; r <= rounds; ++r) {
    if (!((1 SUBSEP r SUBSEP "bondem") in wall) || !((1 SUBSEP r SUBSEP a) in wall) || !((1 SUBSEP r SUBSEP b) in wall)) continue
    v[++n] = wall[1, r, "bondem"] * (1 / wall[1, r, a] + 1 / wall[1, r, b])
    text = text (n > 1 ? ", " : "") sprintf("%.2f", v[n])
    if (!((2 SUBSEP r SUBSEP "bondem") in wall)) continue  # CORES without 2
    f[++m] = wall[1, r, "bondem"] / wall[2, r, "bondem"] / v[n]
    fraction_text = fraction_text (m > 1 ? ", " : "") sprintf("%.2f", f[m])
  }
  if (n > 0) printf "| %s | %s | %s | %.2f |\n", l, title, text, median_of(v, n)
  if (m > 0) printf "| %s | %s | %s | %.2f |\n", l, against, fraction_text, median_of(f, m)
}
$1 == l {
  wall[$3, $4, $2] = $5
  if ($3 == 2 && $9 != "" && $10 != "") {
    placement[$2, $4] = ($9 < kFarNs && $10 < kFarNs) ? "near" : (($9 >= kFarNs && $10 >= kFarNs) ? "far" : "")
  }
  code[$2] = 1
  if ($4 > rounds) rounds = $4
  if ($2 !~ /^bondem/) peer[$2] = 1
  cores[$3] = 1
}
END {
  for (c = 1; c <= 64; ++c) {
    if (!(c in cores)) continue
    n = 0; text = ""
    for (r = 1; r <= rounds; ++r) {
      if (!((c SUBSEP r SUBSEP "bondem") in wall)) continue
      best = 0
      for (k in peer) if (((c SUBSEP r SUBSEP k) in wall) && (best == 0 || wall[c, r, k] < best)) best = wall[c, r, k]
      if (best == 0) continue
      v[++n] = best / wall[c, r, "bondem"]
      text = text (n > 1 ? ", " : "") sprintf("%.2f", v[n])
    }
    if (n > 0) printf "| %s | bondem / faster peer, %d core%s | %s | %.2f |\n", l, c, (c > 1 ? "s" : ""), text, median_of(v, n)
  }
  two_over_one("bondem", "", "bondem two cores over one")
  # With SECOND_CPU: the two-core speed-up a perfect split over the two CPUs would give, from
  # bondem's one-core runs on each alone (1 + t(first) / t(second)) and at the same moment.
  bound_rows("bondem", "bondem-second",
             "two cores over one that a perfect split over both CPUs would give (bondem's one-core runs on each)",
             "bondem two cores over one, against that bound")
  bound_rows("bondem-pair-first", "bondem-pair-second",
             "the same bound with both CPUs busy (two one-core runs at once, one on each)",
             "bondem two cores over one, against the bound with both busy")
  label["near"] = "vCPUs sharing a cache (core to core < " kFarNs " ns)"
  label["far"] = "vCPUs on different dies (core to core > " kFarNs " ns)"
  split("bondem lammps liggghts", names, " ")
  split("near far", kinds, " ")
  for (name = 1; name <= 3; ++name) {
    if (!(names[name] in code)) continue
    for (kind = 1; kind <= 2; ++kind) {
      two_over_one(names[name], kinds[kind], names[name] " two cores over one, " label[kinds[kind]])
    }
  }
}
