#pragma once
/// @file packing.hpp
/// Packing measures of a particle state: solid fraction and coordination number in a region.

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "geometry/box.hpp"
#include "geometry/domain.hpp"
#include "solver/engine/neighbor_list.hpp"
#include "solver/engine/particles.hpp"

namespace bondem {

// Minimum region: in random cubic windows of the settled built-in bed (2 000 spheres), the solid
// fraction with exact clipping scatters (standard deviation) by 0.059 at a side of 1 mean diameter
// (1 centre inside on average), 0.020 at 2 (9 centres), 0.008 at 3 (31 centres), 0.004 at 4 (73
// centres). Below 0.01 is what a bed's solid fraction is read for (random loose ~0.60 against
// random close ~0.64 packing), so a region must span 3 diameters on every axis and hold 30 centres.

/// A measured region must span this many mean particle diameters on every axis.
inline constexpr double kMinRegionDiameters = 3.0;

/// A measured region must hold this many particle centres.
inline constexpr std::size_t kMinRegionParticles = 30;

/// Packing measures in a region.
struct PackingReport {
  std::size_t particles = 0;  ///< particles whose centre lies in the region
  /// Solid volume inside the region (every sphere clipped exactly to it) / region volume; absent
  /// when the region is too small to mean anything (see unmeasured_reason).
  std::optional<double> solid_fraction;
  /// Mean number of particle contacts of the particles centred in the region; absent with
  /// solid_fraction.
  std::optional<double> mean_coordination;
  /// Why the measures are absent ("" when they are present), e.g. "the region is empty along z".
  std::string unmeasured_reason;
};

/// Solid fraction of @p region: the volume of every sphere inside it, clipped exactly by
/// sphere_box_volume (periodic images across @p domain's periodic axes included), over the region
/// volume; and the mean coordination number of the particles centred in it, from @p contacts
/// (per particle, contact_counts()). Both are left out, with the reason, when the region is empty
/// or inverted, spans fewer than kMinRegionDiameters mean diameters on an axis, or holds fewer than
/// kMinRegionParticles centres. The totals are exact (a count, an ExactSum of the volumes): the
/// result does not depend on the particles' order or the thread count.
PackingReport analyse_packing(const Particles& p, const std::vector<int>& contacts,
                              const Box& region, const Domain& domain);

/// The same, with the contacts of the overlaps in @p list.
PackingReport analyse_packing(const Particles& p, const NeighborList& list, const Box& region,
                              const Domain& domain);

/// Per particle of @p p, the partners it overlaps among the pairs of @p list.
std::vector<int> contact_counts(const Particles& p, const NeighborList& list);

/// Bed region: @p box shrunk by @p margin on every side, its top lowered to @p margin below the
/// highest particle top, so that wall and free-surface layers are excluded. It comes out empty
/// (max below min) when the bed is thinner than the margins; analyse_packing then says so.
Box bed_region(const Particles& p, const Box& box, double margin);

}  // namespace bondem
