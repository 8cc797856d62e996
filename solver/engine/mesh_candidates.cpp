#include "solver/engine/mesh_candidates.hpp"

#include <algorithm>
#include <cmath>

namespace bondem {

namespace {

/// How far beyond a particle's radius its list reaches.
double list_margin(const Scene& scene) {
  return scene.contact_range + kMeshCandidateMargin * scene.skin;
}

}  // namespace

void build_mesh_candidates(const Scene& scene, std::vector<MeshCandidates>& candidates) {
  const Particles& p = scene.particles;
  const std::size_t n = p.size();
  candidates.resize(scene.boundaries.size());
  const double margin = list_margin(scene);
  const double max_radius =
      p.radius.empty() ? 0.0 : *std::max_element(p.radius.begin(), p.radius.end());
  for (std::size_t b = 0; b < scene.boundaries.size(); ++b) {
    const Boundary& boundary = scene.boundaries[b];
    MeshCandidates& list = candidates[b];
    const auto* mesh = std::get_if<MeshShape>(&boundary.shape);
    if (mesh == nullptr) {
      list = MeshCandidates{};
      continue;
    }
    list.center_at_build = boundary.center;
    list.angle_at_build = boundary.angle;
    list.arm = mesh->rotation_reach() + max_radius + margin;
    const BoundaryFrame frame = frame_of(boundary);
    const TriangleGrid& grid = mesh->surface->grid;
    // Count, scan, fill: each particle's query is its own, so the lists do not depend on the
    // thread count.
    list.start.assign(n + 1, 0);
#pragma omp parallel if (n >= kMinParallelParticles)
    {
      std::vector<std::int32_t> found;
#pragma omp for schedule(static)
      for (std::size_t i = 0; i < n; ++i) {
        const Eigen::Vector3d w =
            frame.to_body(Eigen::Vector3d(p.x[i], p.y[i], p.z[i]), boundary.center);
        const double reach = p.radius[i] + margin;
        found.clear();
        if (!mesh->surely_apart(w, reach)) query_triangles(grid, w, reach, found);
        list.start[i + 1] = static_cast<std::uint32_t>(found.size());
      }
    }
    for (std::size_t i = 0; i < n; ++i) list.start[i + 1] += list.start[i];
    list.triangles.resize(list.start[n]);
#pragma omp parallel if (n >= kMinParallelParticles)
    {
      std::vector<std::int32_t> found;
#pragma omp for schedule(static)
      for (std::size_t i = 0; i < n; ++i) {
        if (list.start[i] == list.start[i + 1]) continue;
        const Eigen::Vector3d w =
            frame.to_body(Eigen::Vector3d(p.x[i], p.y[i], p.z[i]), boundary.center);
        found.clear();
        query_triangles(grid, w, p.radius[i] + margin, found);
        BoxedTriangle* out = list.triangles.data() + list.start[i];
        for (const std::int32_t t : found) {
          const auto ut = static_cast<std::size_t>(t);
          *out++ = {{grid.box_min[ut].x(), grid.box_min[ut].y(), grid.box_min[ut].z()},
                    {grid.box_max[ut].x(), grid.box_max[ut].y(), grid.box_max[ut].z()},
                    t};
        }
      }
    }
  }
}

bool mesh_moved_half_skin(const Scene& scene, const std::vector<MeshCandidates>& candidates) {
  for (std::size_t b = 0; b < scene.boundaries.size() && b < candidates.size(); ++b) {
    const Boundary& boundary = scene.boundaries[b];
    if (!std::holds_alternative<MeshShape>(boundary.shape) || !boundary.motion.moves()) continue;
    const MeshCandidates& list = candidates[b];
    const double moved = (boundary.center - list.center_at_build).norm() +
                         std::abs(boundary.angle - list.angle_at_build) * list.arm;
    if (moved > 0.5 * scene.skin) return true;
  }
  return false;
}

}  // namespace bondem
