#pragma once
/// @file parallel_sort.hpp
/// A sort on every thread whose result depends on no thread count.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "solver/engine/particles.hpp"

namespace bondem {

/// Sorts @p values by @p less, a strict total order (so the result is the one sorted sequence,
/// whatever the threads): contiguous pieces sorted on every thread, then merged pairwise.
template <class Vector, class Less>
inline void sort_in_parallel(Vector& values, Less less) {
  const std::size_t n = values.size();
  const int threads = threads_in_use(n);
  if (threads < 2 || n < 4 * kMinParallelParticles) {
    std::sort(values.begin(), values.end(), less);
    return;
  }
  const auto pieces = static_cast<std::size_t>(threads);
  std::vector<std::size_t> bounds(pieces + 1);  // piece t is [bounds[t], bounds[t + 1])
  for (std::size_t t = 0; t <= pieces; ++t) bounds[t] = n * t / pieces;
  const auto at = [&](std::size_t b) { return values.begin() + static_cast<std::ptrdiff_t>(b); };
#pragma omp parallel for schedule(static, 1) num_threads(threads)
  for (int t = 0; t < threads; ++t) {
    const auto piece = static_cast<std::size_t>(t);
    std::sort(at(bounds[piece]), at(bounds[piece + 1]), less);
  }
  // Runs of `width` sorted pieces, merged pairwise until one run is left: merge m joins pieces
  // [2mw, 2mw + w) and [2mw + w, 2mw + 2w), the last run alone when it has no partner.
  for (std::size_t width = 1; width < pieces; width *= 2) {
    const auto merges = static_cast<std::int64_t>((pieces + width - 1) / (2 * width));
#pragma omp parallel for schedule(static, 1) num_threads(threads)
    for (std::int64_t m = 0; m < merges; ++m) {
      const std::size_t first = static_cast<std::size_t>(m) * 2 * width;
      const std::size_t last = std::min(first + 2 * width, pieces);
      std::inplace_merge(at(bounds[first]), at(bounds[first + width]), at(bounds[last]), less);
    }
  }
}

}  // namespace bondem
