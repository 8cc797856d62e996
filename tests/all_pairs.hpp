#pragma once
/// @file all_pairs.hpp
/// All-pairs search: exact and O(N^2), the oracle against which the cell-list search is tested
/// (tests only).

#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "geometry/domain.hpp"
#include "solver/engine/particles.hpp"

namespace bondem {

/// Every pair (i < j) whose surfaces are closer than @p skin, with minimum-image distances on the
/// periodic axes of @p domain, in lexicographic order.
inline std::vector<std::pair<std::uint32_t, std::uint32_t>> find_pairs_all(const Particles& p,
                                                                           const Domain& domain,
                                                                           double skin) {
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs;
  const Eigen::Vector3d length = domain.length();
  const std::size_t n = p.size();
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      double d[3] = {p.x[j] - p.x[i], p.y[j] - p.y[i], p.z[j] - p.z[i]};
      for (int a = 0; a < 3; ++a) {
        if (domain.periodic[a]) d[a] -= length[a] * std::nearbyint(d[a] / length[a]);
      }
      const double reach = p.radius[i] + p.radius[j] + skin;
      if (d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < reach * reach) {
        pairs.emplace_back(static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(j));
      }
    }
  }
  return pairs;
}

}  // namespace bondem
