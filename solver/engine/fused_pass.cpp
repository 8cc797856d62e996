#include "solver/engine/fused_pass.hpp"

#include <algorithm>
#include <atomic>
#include <cstdint>

namespace bondem {

namespace {
std::atomic<std::size_t> fused_from{std::size_t{1} << 19};
std::atomic<std::size_t> shape_run_rows{4096};
std::atomic<std::uint32_t> shape_ring_pairs{65536};

/// The first element of @p storage on a 64-B line.
double* line_start(std::vector<double>& storage) {
  double* start = storage.data();
  while (reinterpret_cast<std::uintptr_t>(start) % 64 != 0) ++start;
  return start;
}
}  // namespace

std::size_t set_fused_pass_from(std::size_t particles) {
  return fused_from.exchange(particles, std::memory_order_relaxed);
}

std::size_t fused_pass_from() {
  return fused_from.load(std::memory_order_relaxed);
}

std::pair<std::size_t, std::uint32_t> set_fused_pass_shape(std::size_t run_rows,
                                                           std::uint32_t ring_pairs) {
  return {shape_run_rows.exchange(run_rows, std::memory_order_relaxed),
          shape_ring_pairs.exchange(ring_pairs, std::memory_order_relaxed)};
}

void plan_fused_pass(const NeighborList& list, std::size_t particles, bool friction, int shares,
                     FusedPlan& plan) {
  const std::size_t n = particles;
  const StaggeredVector<std::uint32_t>& row_begin = list.row_begins();
  const std::uint32_t* second = list.seconds();
  const std::size_t run_rows = shape_run_rows.load(std::memory_order_relaxed);
  plan.builds = list.build_count();
  plan.particles = n;
  plan.friction = friction;
  plan.shares = shares;
  plan.run_rows = run_rows;
  std::uint32_t most_pairs = 0;
  for (std::size_t row = 0; row < n; row += run_rows) {
    most_pairs = std::max(most_pairs, row_begin[std::min(n, row + run_rows)] - row_begin[row]);
  }
  // At least two runs' pairs: a run's own, and those written a run before that its particles read.
  std::uint32_t ring_pairs = shape_ring_pairs.load(std::memory_order_relaxed);
  while (ring_pairs < 2 * std::size_t{most_pairs}) ring_pairs *= 2;
  plan.ring_pairs = ring_pairs;
  // A particle waits when one of its pairs sits in a row past its run, or was written more than
  // a ring before its run ends (its own row's pairs are its run's).
  const auto run_end = [&](std::size_t i) { return std::min(n, (i / run_rows + 1) * run_rows); };
  plan.waits.assign(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::uint32_t k = row_begin[i]; k < row_begin[i + 1]; ++k) {
      const std::uint32_t j = second[k];
      const std::size_t end = run_end(j);
      if (i >= end || row_begin[end] - k > ring_pairs) plan.waits[j] = 1;
    }
  }
  plan.waiting.clear();
  std::size_t waiting = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (plan.waits[i] == 0) continue;
    ++waiting;
    if (!plan.waiting.empty() && plan.waiting.back() == i) {
      ++plan.waiting.back();
    } else {
      plan.waiting.push_back(static_cast<std::uint32_t>(i));
      plan.waiting.push_back(static_cast<std::uint32_t>(i + 1));
    }
  }
  const auto count = static_cast<std::size_t>(std::max(shares, 1));
  // A list whose pairs lie far from their particles in memory (ids that do not follow the cells'
  // order): the two passes, and nothing kept for it.
  const auto unusable = [&] {
    plan.usable = false;
    std::vector<std::uint8_t>().swap(plan.waits);
    std::vector<std::uint32_t>().swap(plan.waiting);
    std::vector<std::uint64_t>().swap(plan.bits);
    std::vector<std::uint32_t>().swap(plan.rank);
    std::vector<std::vector<double>>().swap(plan.ring_storage);
    std::vector<double>().swap(plan.kept_records);
  };
  if (waiting > n / 8) return unusable();
  // The reach, and the pairs of the particles that always wait, marked.
  plan.reach = 0;
  plan.bits.assign((list.pair_count() + 63) / 64 + 1, 0);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::uint32_t k = row_begin[i]; k < row_begin[i + 1]; ++k) {
      const std::uint32_t j = second[k];
      if (plan.waits[j] == 0) plan.reach = std::max(plan.reach, i > j ? i - j : j - i);
      if ((plan.waits[i] | plan.waits[j]) != 0) plan.bits[k >> 6] |= std::uint64_t{1} << (k & 63);
    }
  }
  plan.rank.resize(plan.bits.size());
  std::uint32_t marked = 0;
  for (std::size_t word = 0; word < plan.bits.size(); ++word) {
    plan.rank[word] = marked;
    marked += static_cast<std::uint32_t>(__builtin_popcountll(plan.bits[word]));
  }
  plan.marked = marked;
  if (count > 1 && plan.reach * count * 4 > n) return unusable();
  plan.usable = true;
  // Records (8 doubles a pair) or three slot arrays, each a ring and a run past it (a run's pairs
  // lie contiguous until the part past the ring's end is moved to its front), on 64-B lines.
  const std::size_t span = std::size_t{ring_pairs} + most_pairs + 64;
  const std::size_t values = friction ? 8 * span + 8 : 3 * span + 32;
  plan.ring_storage.resize(count);
  for (std::vector<double>& storage : plan.ring_storage) storage.assign(values, 0.0);
}

void cut_fused_pass(FusedPlan& plan, const NeighborList& list, std::span<const std::size_t> cuts,
                    FusedCuts& out) {
  const std::size_t shares = cuts.size() - 1;
  const std::size_t n = cuts.back();
  const StaggeredVector<std::uint32_t>& row_begin = list.row_begins();
  const std::uint32_t* second = list.seconds();
  out.windows.clear();
  std::vector<std::uint32_t> found(plan.waiting);
  std::uint32_t base = plan.marked;
  for (std::size_t s = 1; s < shares; ++s) {
    // Next to the cut, a particle one of whose pairs sits in a row on the other side waits (the
    // rows within the reach of the cut hold all such pairs); so do all the particles from the
    // first to the last of them: scattered, they would cut the runs into pieces too short for
    // pass 2 and the drift.
    const std::size_t cut = cuts[s];
    const std::size_t from = std::max(cuts[s - 1], cut > plan.reach ? cut - plan.reach : 0);
    const std::size_t to = std::min(cuts[s + 1], cut + plan.reach + 1);
    std::size_t first = n, end = 0;
    for (std::size_t i = from; i < to; ++i) {
      for (std::uint32_t k = row_begin[i]; k < row_begin[i + 1]; ++k) {
        const std::uint32_t j = second[k];
        if ((i < cut) == (j < cut) || plan.waits[j] != 0) continue;
        first = std::min<std::size_t>(first, j);
        end = std::max<std::size_t>(end, j + std::size_t{1});
      }
    }
    if (first >= end) continue;
    found.push_back(static_cast<std::uint32_t>(first));
    found.push_back(static_cast<std::uint32_t>(end));
    // Their pairs lie in the rows within the reach of them (those that always wait have theirs
    // marked): kept by the shares on either side of the cut.
    const std::size_t low = first > plan.reach ? first - plan.reach : 0;
    const std::size_t high = std::min(n, end + plan.reach + 1);
    out.windows.insert(out.windows.end(), {row_begin[low], row_begin[high], base});
    base += row_begin[high] - row_begin[low];
  }
  // Sorted and merged.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> sorted;
  for (std::size_t r = 0; r < found.size(); r += 2) sorted.emplace_back(found[r], found[r + 1]);
  std::sort(sorted.begin(), sorted.end());
  out.ranges.clear();
  for (const auto& [first, end] : sorted) {
    if (!out.ranges.empty() && out.ranges.back() >= first) {
      out.ranges.back() = std::max(out.ranges.back(), end);
    } else {
      out.ranges.push_back(first);
      out.ranges.push_back(end);
    }
  }
  if (plan.kept_records.size() < 8 * std::size_t{base} + 8) {
    plan.kept_records.resize(8 * std::size_t{base} + 8);
  }
  out.kept = KeptPairs{plan.bits.data(), plan.rank.data(), out.windows.data(),
                       static_cast<int>(out.windows.size() / 3), line_start(plan.kept_records)};
}

FusedRing fused_ring(FusedPlan& plan, const FusedCuts& cuts, int share) {
  double* start = line_start(plan.ring_storage[static_cast<std::size_t>(share)]);
  FusedRing ring;
  if (plan.friction) {
    // Pass 2 reads a pair's record, one line, where it read seven arrays' lines.
    ring.records = start;
  } else {
    // Each array a line after the last, so that their elements fall into different sets.
    const std::size_t stride = plan.ring_storage[static_cast<std::size_t>(share)].size() / 3 - 8;
    for (std::size_t v = 0; v < 3; ++v) ring.slots[v] = start + v * stride + 8 * v;
  }
  ring.pairs = plan.ring_pairs;
  ring.kept = cuts.kept;
  ring.run_rows = plan.run_rows;
  return ring;
}

}  // namespace bondem
