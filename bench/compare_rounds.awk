# Per round of compare_peers.sh's timings.csv (lattice,code,cores,rep,wall,...), for lattice l:
# bondem's wall time against the faster peer's of the same round at each core count, and bondem's
# one core against its two cores, each as the list of rounds and its median. A round runs every
# code once, back to back, so its ratios share the host's state of the moment.
function median_of(v, n,    i, j, t) {
  for (i = 2; i <= n; ++i) for (j = i; j > 1 && v[j - 1] > v[j]; --j) { t = v[j]; v[j] = v[j - 1]; v[j - 1] = t }
  return n % 2 ? v[(n + 1) / 2] : (v[n / 2] + v[n / 2 + 1]) / 2
}
$1 == l {
  wall[$3, $4, $2] = $5
  if ($4 > rounds) rounds = $4
  if ($2 != "bondem") peer[$2] = 1
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
  n = 0; text = ""
  for (r = 1; r <= rounds; ++r) {
    if (!((1 SUBSEP r SUBSEP "bondem") in wall) || !((2 SUBSEP r SUBSEP "bondem") in wall)) continue
    v[++n] = wall[1, r, "bondem"] / wall[2, r, "bondem"]
    text = text (n > 1 ? ", " : "") sprintf("%.2f", v[n])
  }
  if (n > 0) printf "| %s | bondem two cores over one | %s | %.2f |\n", l, text, median_of(v, n)
}
