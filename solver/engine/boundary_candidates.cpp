#include "solver/engine/boundary_candidates.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <variant>

namespace bondem {

namespace {

/// How far beyond a particle's radius its list reaches.
double list_margin(const Scene& scene) {
  return scene.contact_range + kBoundaryCandidateMargin * scene.skin;
}

/// The particles of @p p within reach of analytic @p boundary (seen in @p frame), each within its
/// radius plus @p margin, in ascending order into @p near. Each thread takes a contiguous range
/// of particles, so the threads' finds joined in thread order are the ascending list whatever
/// the thread count.
void gather_near(const Particles& p, const Boundary& boundary, const BoundaryFrame& frame,
                 double margin, std::vector<std::uint32_t>& near) {
  const std::size_t n = p.size();
  const int threads = threads_in_use(n);
  std::vector<std::vector<std::uint32_t>> found(static_cast<std::size_t>(threads));
#pragma omp parallel num_threads(threads) if (n >= kMinParallelParticles)
  {
    std::vector<std::uint32_t>& mine = found[static_cast<std::size_t>(omp_get_thread_num())];
#pragma omp for schedule(static)
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d w =
          frame.to_body(Eigen::Vector3d(p.x[i], p.y[i], p.z[i]), boundary.center);
      const bool apart =
          std::visit([&](const auto& shape) { return shape.surely_apart(w, p.radius[i] + margin); },
                     boundary.shape);
      if (!apart) mine.push_back(static_cast<std::uint32_t>(i));
    }
  }
  for (const std::vector<std::uint32_t>& part : found)
    near.insert(near.end(), part.begin(), part.end());
}

/// The farthest surface point of @p boundary from its reference point (rotation_reach).
double rotation_reach(const Boundary& boundary) {
  return std::visit([](const auto& shape) { return shape.rotation_reach(); }, boundary.shape);
}

}  // namespace

void build_boundary_candidates(const Scene& scene, std::vector<BoundaryCandidates>& candidates) {
  const Particles& p = scene.particles;
  const std::size_t n = p.size();
  candidates.resize(scene.boundaries.size());
  const double margin = list_margin(scene);
  const double max_radius =
      p.radius.empty() ? 0.0 : *std::max_element(p.radius.begin(), p.radius.end());
  for (std::size_t b = 0; b < scene.boundaries.size(); ++b) {
    const Boundary& boundary = scene.boundaries[b];
    BoundaryCandidates& list = candidates[b];
    list = BoundaryCandidates{};
    list.center_at_build = boundary.center;
    list.angle_at_build = boundary.angle;
    list.arm = rotation_reach(boundary) + max_radius + margin;
    const BoundaryFrame frame = frame_of(boundary);
    const auto* mesh = std::get_if<MeshShape>(&boundary.shape);
    if (mesh == nullptr) {
      gather_near(p, boundary, frame, margin, list.near);
      continue;
    }
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

bool boundary_moved_half_skin(const Scene& scene,
                              const std::vector<BoundaryCandidates>& candidates) {
  for (std::size_t b = 0; b < scene.boundaries.size() && b < candidates.size(); ++b) {
    const Boundary& boundary = scene.boundaries[b];
    if (!boundary.motion.moves()) continue;
    const BoundaryCandidates& list = candidates[b];
    // A turn moves a surface point by the angle times its distance from the axis; the arm of an
    // unbounded shape (a plane) is infinite, and an angle that did not change adds nothing.
    const double turn = boundary.angle - list.angle_at_build;
    const double moved = (boundary.center - list.center_at_build).norm() +
                         (turn == 0.0 ? 0.0 : std::abs(turn) * list.arm);
    if (moved > 0.5 * scene.skin) return true;
  }
  return false;
}

}  // namespace bondem
