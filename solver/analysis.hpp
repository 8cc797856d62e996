#pragma once
/// @file analysis.hpp
/// Packing measures of a particle state: solid fraction and coordination number in a region.

#include "geometry/box.hpp"
#include "solver/neighbor_list.hpp"
#include "solver/particles.hpp"

namespace bondem {

/// Packing measures of the particles whose centres lie in a region.
struct PackingReport {
  std::size_t particles = 0;       ///< particles counted
  double solid_fraction = 0.0;     ///< their sphere volume / region volume
  double mean_coordination = 0.0;  ///< mean number of particle contacts per counted particle
};

/// Solid fraction by centres (the volume of spheres centred inside over the region volume: an
/// unbiased estimate for a homogeneous packing when the region spans many diameters) and the mean
/// coordination number of those particles, from the overlaps in @p list.
PackingReport analyse_packing(const Particles& p, const NeighborList& list, const Box& region);

/// Bed region: @p box shrunk by @p margin on every side, its top lowered to @p margin below the
/// highest particle top, so that wall and free-surface layers are excluded.
Box bed_region(const Particles& p, const Box& box, double margin);

}  // namespace bondem
