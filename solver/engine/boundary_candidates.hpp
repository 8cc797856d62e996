#pragma once
/// @file boundary_candidates.hpp
/// Verlet lists for boundaries, gathered with the pair list: per mesh boundary and particle, the
/// triangles that can come into contact before the next rebuild, so that a step tests a handful
/// of triangles per particle instead of querying the mesh's grid (LIGGGHTS keeps such lists too,
/// in its mesh neighbor lists); per analytic boundary (plane, box, cylinder, sphere), the
/// particles that can reach it, so that a step tests those only. A floor under a deep bed or the
/// walls of a container are within reach of a few particles: testing every particle against
/// every boundary took as long as summing the pairs (pass 2 of the 20 800 peer lattice).
///
/// They only narrow the search: the contacts found among them are the ones the full search finds
/// (mesh_contacts_among), so when they are rebuilt does not change any result. A particle
/// without candidates (no triangle of a mesh, or left out of an analytic boundary's list) has no
/// contact with the boundary and no history to release, and is not tested at all: a contact's
/// history is released at the first evaluation out of contact, and a particle in contact at that
/// evaluation is within reach when the lists are gathered next.
///
/// Validity. A list is gathered with the contact reach plus a margin of 1.5 skins. Until the
/// next rebuild a particle moves at most one skin from where the list saw it (half a skin from
/// the pair list's build positions, which are at most half a skin from the boundary list's), and
/// the stepper gathers the lists again when a boundary itself has moved half a skin relative to
/// any particle in reach (boundary_moved_half_skin): so no triangle or particle outside a list
/// comes within reach.

#include <cstdint>
#include <vector>

#include "geometry/triangle_mesh.hpp"
#include "solver/engine/scene.hpp"

namespace bondem {

/// The candidates of one boundary: for a mesh, every particle's candidate triangles; for an
/// analytic shape, the particles in reach.
struct BoundaryCandidates {
  std::vector<std::uint32_t> start;      ///< mesh: per particle, CSR into triangles (size n + 1)
  std::vector<BoxedTriangle> triangles;  ///< mesh: in the mesh's own numbering, with their boxes
  std::vector<std::uint32_t> near;       ///< analytic shape: the particles in reach, ascending
  Eigen::Vector3d center_at_build = Eigen::Vector3d::Zero();  ///< the boundary's pose when gathered
  double angle_at_build = 0.0;
  /// Farthest from the reference point a particle in reach can be when gathered [m]: the lever
  /// of the boundary's turn.
  double arm = 0.0;
};

/// Margin of the lists beyond the contact reach, in skins (see the file comment).
inline constexpr double kBoundaryCandidateMargin = 1.5;

/// Gather the lists of every boundary of @p scene for the particles' current positions;
/// @p candidates gets one entry per boundary.
void build_boundary_candidates(const Scene& scene, std::vector<BoundaryCandidates>& candidates);

/// Whether some boundary has moved, relative to a particle within its reach, more than half a
/// skin since its list was gathered: by its reference point's travel plus its turn times the
/// largest distance from that point at which a particle can touch it.
bool boundary_moved_half_skin(const Scene& scene,
                              const std::vector<BoundaryCandidates>& candidates);

}  // namespace bondem
