#include "geometry/triangle_mesh.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace bondem {

void compute_normals(TriangleMesh& mesh) {
  mesh.normals.resize(mesh.triangles.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& [i, j, k] = mesh.triangles[t];
    const Eigen::Vector3d n =
        (mesh.vertices[j] - mesh.vertices[i]).cross(mesh.vertices[k] - mesh.vertices[i]);
    const double length = n.norm();
    mesh.normals[t] = length > 0.0 ? Eigen::Vector3d(n / length) : Eigen::Vector3d::Zero();
  }
}

TriangleMesh tessellated_square(double lo, double hi, int n) {
  TriangleMesh mesh;
  for (int j = 0; j <= n; ++j) {
    for (int i = 0; i <= n; ++i) {
      mesh.vertices.emplace_back(lo + (hi - lo) * i / n, lo + (hi - lo) * j / n, 0.0);
    }
  }
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const int v = j * (n + 1) + i;
      mesh.triangles.push_back({v, v + 1, v + n + 2});
      mesh.triangles.push_back({v, v + n + 2, v + n + 1});
    }
  }
  compute_normals(mesh);
  return mesh;
}

namespace {

// Cells of the grid at most; larger meshes get larger cells (memory stays a few megabytes).
constexpr double kMaxCells = 2097152.0;

int cell_of(double x, double origin, double cell_size, int cells) {
  const double f = std::floor((x - origin) / cell_size);
  if (f < 0.0) return 0;
  if (f >= cells - 1) return cells - 1;
  return static_cast<int>(f);
}

// The contact of the sphere with triangle t when its closest point is nearer than the radius.
bool triangle_contact(const TriangleMesh& mesh, std::int32_t t, const Eigen::Vector3d& centre,
                      double radius, MeshContact& contact) {
  const auto& [i, j, k] = mesh.triangles[t];
  const Eigen::Vector3d& a = mesh.vertices[i];
  const TriangleClosest closest =
      closest_on_triangle(centre, a, mesh.vertices[j], mesh.vertices[k]);
  const Eigen::Vector3d d = centre - closest.point;
  const double distance2 = d.squaredNorm();
  if (distance2 >= radius * radius) return false;
  contact.point = closest.point;
  contact.triangle = t;
  contact.region = closest.region;
  const Eigen::Vector3d& n = mesh.normals[t];
  if (is_face(closest.region)) {
    // The plane distance and the face normal are exact to round-off, where d / |d| would carry
    // the error of the projected point into the direction.
    const double height = (centre - a).dot(n);
    contact.gap = std::abs(height);
    contact.normal = height >= 0.0 ? n : Eigen::Vector3d(-n);
  } else {
    const double distance = std::sqrt(distance2);
    contact.gap = distance;
    contact.normal = distance > 0.0 ? Eigen::Vector3d(d / distance) : n;
  }
  return true;
}

int rank_of(TriangleRegion region) {
  if (is_face(region)) return 0;
  return is_vertex(region) ? 2 : 1;
}

// The double-contact rule of triangle_mesh.hpp: faces, then edges, then vertices, each nearest
// first (ties in triangle order, so the order is total and the result deterministic); a candidate
// on or behind the tangent plane of an accepted contact (a coinciding point included) is dropped.
void resolve_contacts(double radius, MeshQueryBuffer& buffer) {
  const double tol = kMeshContactTolerance * radius;
  std::sort(buffer.candidates.begin(), buffer.candidates.end(),
            [](const MeshContact& a, const MeshContact& b) {
              const int ra = rank_of(a.region);
              const int rb = rank_of(b.region);
              if (ra != rb) return ra < rb;
              if (a.gap != b.gap) return a.gap < b.gap;
              return a.triangle < b.triangle;
            });
  buffer.contacts.clear();
  for (const MeshContact& candidate : buffer.candidates) {
    bool redundant = false;
    for (const MeshContact& accepted : buffer.contacts) {
      if ((candidate.point - accepted.point).dot(accepted.normal) <= tol) {
        redundant = true;
        break;
      }
    }
    if (!redundant) buffer.contacts.push_back(candidate);
  }
}

}  // namespace

TriangleGrid build_triangle_grid(const TriangleMesh& mesh, double cell_size) {
  if (!(cell_size > 0.0)) throw std::invalid_argument("triangle grid: cell size must be > 0");
  TriangleGrid grid;
  const std::size_t n = mesh.triangles.size();
  grid.box_min.resize(n);
  grid.box_max.resize(n);
  grid.first_cell.resize(n);
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(0.0);
  Eigen::Vector3d hi = Eigen::Vector3d::Constant(0.0);
  for (std::size_t t = 0; t < n; ++t) {
    const auto& [i, j, k] = mesh.triangles[t];
    grid.box_min[t] = mesh.vertices[i].cwiseMin(mesh.vertices[j]).cwiseMin(mesh.vertices[k]);
    grid.box_max[t] = mesh.vertices[i].cwiseMax(mesh.vertices[j]).cwiseMax(mesh.vertices[k]);
    lo = t == 0 ? grid.box_min[t] : Eigen::Vector3d(lo.cwiseMin(grid.box_min[t]));
    hi = t == 0 ? grid.box_max[t] : Eigen::Vector3d(hi.cwiseMax(grid.box_max[t]));
  }
  const Eigen::Vector3d extent = hi - lo;
  double h = cell_size;
  const auto count_cells = [&](double size) {
    return (extent / size).array().floor().max(0.0).matrix() + Eigen::Vector3d::Ones();
  };
  const double total = count_cells(h).prod();
  if (total > kMaxCells) h *= std::cbrt(total / kMaxCells) * (1.0 + 1.0e-12);
  const Eigen::Vector3d cells = count_cells(h);
  grid.origin = lo;
  grid.cell_size = h;
  for (int axis = 0; axis < 3; ++axis) grid.cells[axis] = static_cast<int>(cells[axis]);
  const auto [nx, ny, nz] = grid.cells;
  // Count, scan, fill: each triangle goes into every cell its box meets, in triangle order.
  grid.cell_start.assign(static_cast<std::size_t>(nx) * ny * nz + 1, 0);
  std::array<int, 3> first{};
  std::array<int, 3> last{};
  const auto range = [&](std::size_t t) {
    for (int axis = 0; axis < 3; ++axis) {
      first[axis] = cell_of(grid.box_min[t][axis], lo[axis], h, grid.cells[axis]);
      last[axis] = cell_of(grid.box_max[t][axis], lo[axis], h, grid.cells[axis]);
    }
  };
  for (std::size_t t = 0; t < n; ++t) {
    range(t);
    grid.first_cell[t] = first;
    for (int z = first[2]; z <= last[2]; ++z)
      for (int y = first[1]; y <= last[1]; ++y)
        for (int x = first[0]; x <= last[0]; ++x)
          ++grid.cell_start[(static_cast<std::size_t>(z) * ny + y) * nx + x + 1];
  }
  for (std::size_t k = 1; k < grid.cell_start.size(); ++k)
    grid.cell_start[k] += grid.cell_start[k - 1];
  grid.cell_triangles.resize(static_cast<std::size_t>(grid.cell_start.back()));
  std::vector<std::int32_t> fill(grid.cell_start.begin(), grid.cell_start.end() - 1);
  for (std::size_t t = 0; t < n; ++t) {
    range(t);
    for (int z = first[2]; z <= last[2]; ++z)
      for (int y = first[1]; y <= last[1]; ++y)
        for (int x = first[0]; x <= last[0]; ++x)
          grid.cell_triangles[fill[(static_cast<std::size_t>(z) * ny + y) * nx + x]++] =
              static_cast<std::int32_t>(t);
  }
  return grid;
}

void query_triangles(const TriangleGrid& grid, const Eigen::Vector3d& centre, double radius,
                     std::vector<std::int32_t>& out) {
  if (grid.box_min.empty()) return;
  const double h = grid.cell_size;
  const Eigen::Vector3d qmin = centre.array() - radius;
  const Eigen::Vector3d qmax = centre.array() + radius;
  const Eigen::Vector3d gmax =
      grid.origin + h * Eigen::Vector3d(grid.cells[0], grid.cells[1], grid.cells[2]);
  // The last cells reach beyond gmax only when the extent is a multiple of h; the boxes do not.
  if ((qmax.array() < grid.origin.array()).any() || (qmin.array() > gmax.array()).any()) return;
  std::array<int, 3> lo{};
  std::array<int, 3> hi{};
  for (int axis = 0; axis < 3; ++axis) {
    lo[axis] = cell_of(qmin[axis], grid.origin[axis], h, grid.cells[axis]);
    hi[axis] = cell_of(qmax[axis], grid.origin[axis], h, grid.cells[axis]);
  }
  const auto [nx, ny, nz] = grid.cells;
  for (int z = lo[2]; z <= hi[2]; ++z) {
    for (int y = lo[1]; y <= hi[1]; ++y) {
      for (int x = lo[0]; x <= hi[0]; ++x) {
        const std::size_t cell = (static_cast<std::size_t>(z) * ny + y) * nx + x;
        for (std::int32_t k = grid.cell_start[cell]; k < grid.cell_start[cell + 1]; ++k) {
          const std::int32_t t = grid.cell_triangles[k];
          const std::array<int, 3>& f = grid.first_cell[t];
          // A triangle in several queried cells is reported from the lowest of them only.
          if (x != std::max(lo[0], f[0]) || y != std::max(lo[1], f[1]) ||
              z != std::max(lo[2], f[2]))
            continue;
          // The sphere, not its box, against the triangle's box: on a finely tessellated
          // surface this leaves the few triangles under the sphere out of the dozens its box
          // meets, before any closest-point test.
          const Eigen::Vector3d outside =
              (grid.box_min[t] - centre).cwiseMax(centre - grid.box_max[t]).cwiseMax(0.0);
          if (outside.squaredNorm() >= radius * radius) continue;
          out.push_back(t);
        }
      }
    }
  }
}

std::span<const MeshContact> mesh_contacts(const TriangleMesh& mesh, const TriangleGrid& grid,
                                           const Eigen::Vector3d& centre, double radius,
                                           MeshQueryBuffer& buffer) {
  buffer.triangles.clear();
  query_triangles(grid, centre, radius, buffer.triangles);
  // Candidates come in cell order; resolve_contacts sorts them by a total order (rank, gap,
  // triangle), which makes the result independent of the grid.
  buffer.candidates.clear();
  MeshContact contact;
  for (const std::int32_t t : buffer.triangles)
    if (triangle_contact(mesh, t, centre, radius, contact)) buffer.candidates.push_back(contact);
  resolve_contacts(radius, buffer);
  return buffer.contacts;
}

std::span<const MeshContact> mesh_contacts_among(const TriangleMesh& mesh,
                                                 std::span<const BoxedTriangle> triangles,
                                                 const Eigen::Vector3d& centre, double radius,
                                                 MeshQueryBuffer& buffer) {
  // In the caller's order; resolve_contacts sorts by a total order (rank, gap, triangle), which
  // makes the result independent of it and of triangles out of reach.
  buffer.candidates.clear();
  MeshContact contact;
  const double r2 = radius * radius;
  for (const BoxedTriangle& boxed : triangles) {
    // Out of reach of the triangle's box: no closest point to compute (most of a list).
    double outside2 = 0.0;
    for (int axis = 0; axis < 3; ++axis) {
      const double below = boxed.box_min[axis] - centre[axis];
      const double above = centre[axis] - boxed.box_max[axis];
      const double out = std::max(std::max(below, above), 0.0);
      outside2 += out * out;
    }
    if (outside2 >= r2) continue;
    if (triangle_contact(mesh, boxed.triangle, centre, radius, contact)) {
      buffer.candidates.push_back(contact);
    }
  }
  resolve_contacts(radius, buffer);
  return buffer.contacts;
}

std::span<const MeshContact> mesh_contacts_brute_force(const TriangleMesh& mesh,
                                                       const Eigen::Vector3d& centre, double radius,
                                                       MeshQueryBuffer& buffer) {
  buffer.candidates.clear();
  MeshContact contact;
  const auto n = static_cast<std::int32_t>(mesh.triangles.size());
  for (std::int32_t t = 0; t < n; ++t)
    if (triangle_contact(mesh, t, centre, radius, contact)) buffer.candidates.push_back(contact);
  resolve_contacts(radius, buffer);
  return buffer.contacts;
}

}  // namespace bondem
