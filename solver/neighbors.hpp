#pragma once
/// @file neighbors.hpp
/// Candidate contact pairs. The all-pairs search here is exact and serves as the oracle for the
/// cell-list search that replaces it for large particle counts.

#include <cstdint>
#include <vector>

#include "solver/particles.hpp"

namespace bondem {

/// Two particle indices with i < j.
struct ContactPair {
  std::uint32_t i;
  std::uint32_t j;
};

/// All pairs whose surfaces are closer than @p skin, in lexicographic (i, j) order. O(N^2).
inline void find_pairs_all(const Particles& p, double skin, std::vector<ContactPair>& pairs) {
  pairs.clear();
  const std::size_t n = p.size();
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      const double dx = p.x[j] - p.x[i];
      const double dy = p.y[j] - p.y[i];
      const double dz = p.z[j] - p.z[i];
      const double reach = p.radius[i] + p.radius[j] + skin;
      if (dx * dx + dy * dy + dz * dz < reach * reach) {
        pairs.push_back({static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(j)});
      }
    }
  }
}

}  // namespace bondem
