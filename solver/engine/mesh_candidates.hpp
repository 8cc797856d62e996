#pragma once
/// @file mesh_candidates.hpp
/// Verlet lists for triangle meshes: per mesh boundary and particle, the triangles that can come
/// into contact before the next rebuild, so that a step tests a handful of triangles per particle
/// instead of querying the mesh's grid (LIGGGHTS keeps such lists too, in its mesh neighbor
/// lists). They only narrow the search: the contacts found among them are the ones the full
/// search finds (mesh_contacts_among), so when they are rebuilt does not change any result.
///
/// Validity. A list is gathered with the contact reach plus a margin of 1.5 skins. Until the
/// next rebuild a particle moves at most one skin from where the list saw it (half a skin from
/// the pair list's build positions, which are at most half a skin from the mesh list's), and the
/// stepper rebuilds the mesh lists when a mesh itself has moved half a skin relative to any
/// particle in reach (mesh_moved_half_skin): so no triangle outside a list comes within reach.

#include <cstdint>
#include <vector>

#include "geometry/triangle_mesh.hpp"
#include "solver/engine/scene.hpp"

namespace bondem {

/// The candidate triangles of every particle for one mesh boundary (empty for other shapes).
struct MeshCandidates {
  std::vector<std::uint32_t> start;      ///< per particle, CSR into triangles (size n + 1)
  std::vector<BoxedTriangle> triangles;  ///< in the mesh's own numbering, with their boxes
  Eigen::Vector3d center_at_build = Eigen::Vector3d::Zero();  ///< the mesh's pose when gathered
  double angle_at_build = 0.0;
  /// Farthest from the reference point a particle in reach can be when gathered [m]: the lever
  /// of the mesh's turn.
  double arm = 0.0;
};

/// Margin of the lists beyond the contact reach, in skins (see the file comment).
inline constexpr double kMeshCandidateMargin = 1.5;

/// Gather the lists of every mesh boundary of @p scene for the particles' current positions;
/// @p candidates gets one entry per boundary.
void build_mesh_candidates(const Scene& scene, std::vector<MeshCandidates>& candidates);

/// Whether some mesh has moved, relative to a particle within its reach, more than half a skin
/// since its list was gathered: by its reference point's travel plus its turn times the largest
/// distance from that point at which a particle can touch it.
bool mesh_moved_half_skin(const Scene& scene, const std::vector<MeshCandidates>& candidates);

}  // namespace bondem
