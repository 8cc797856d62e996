#include "geometry/boundary_shapes.hpp"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>

namespace bondem {

namespace {

/// FNV-1a over the bytes of @p data, continuing from @p hash.
template <class T>
std::uint64_t fnv1a(std::uint64_t hash, const T& data) {
  unsigned char bytes[sizeof(T)];
  std::memcpy(bytes, &data, sizeof(T));
  for (const unsigned char byte : bytes) {
    hash ^= byte;
    hash *= 1099511628211ULL;
  }
  return hash;
}

}  // namespace

std::shared_ptr<const MeshSurface> make_mesh_surface(TriangleMesh mesh, double cell_size,
                                                     std::string file) {
  auto surface = std::make_shared<MeshSurface>();
  compute_normals(mesh);
  std::uint64_t hash = 14695981039346656037ULL;
  if (!mesh.vertices.empty()) {
    surface->box_min = surface->box_max = mesh.vertices.front();
  }
  for (const Eigen::Vector3d& v : mesh.vertices) {
    surface->box_min = surface->box_min.cwiseMin(v);
    surface->box_max = surface->box_max.cwiseMax(v);
    surface->reach = std::max(surface->reach, v.norm());
    for (int a = 0; a < 3; ++a) hash = fnv1a(hash, v[a]);
  }
  for (const auto& t : mesh.triangles) {
    for (const int index : t) hash = fnv1a(hash, static_cast<std::int32_t>(index));
  }
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(hash));
  surface->checksum = text;
  if (!(cell_size > 0.0)) {
    // No particle size to go by: cells of the longest edge.
    for (const auto& t : mesh.triangles) {
      for (int k = 0; k < 3; ++k) {
        cell_size = std::max(cell_size, (mesh.vertices[static_cast<std::size_t>(t[k])] -
                                         mesh.vertices[static_cast<std::size_t>(t[(k + 1) % 3])])
                                            .norm());
      }
    }
  }
  surface->grid = build_triangle_grid(mesh, cell_size);
  surface->mesh = std::move(mesh);
  surface->file = std::move(file);
  return surface;
}

}  // namespace bondem
