#pragma once
/// @file triangle_mesh.hpp
/// Triangle meshes as boundaries: the mesh, the closest point on one triangle, a uniform cell grid
/// over the triangles, and the contacts of a sphere with the mesh, one per touched surface feature.
///
/// The double-contact rule (mesh_contacts). A sphere near a shared edge or vertex finds a closest
/// point on every triangle around it; counting each would push it two, four or eight times.
/// LIGGGHTS (CFDEMproject/LIGGGHTS-PUBLIC, src/surface_mesh_I.h, src/tri_mesh_I.h) settles it
/// with a topology pass: edges between coplanar triangles, one of the two copies of every other
/// shared edge, and corners without an active edge are marked inactive, and a contact landing in
/// an inactive edge or corner region is dropped. Su et al. (2011) and Hu et al. (2013) drop instead
/// the contacts whose contact point is already represented by a face or nearer contact. bondem
/// decides per query, from the geometry alone (no topology to build, keep or move with the mesh):
///   1. every triangle whose closest point q is nearer than the radius is a candidate, tagged with
///      its region (face, edge, vertex), its gap |c - q| and its normal n = (c - q) / |c - q| (the
///      face normal, signed towards the centre, in a face region);
///   2. candidates are taken faces first, then edges, then vertices; within a rank nearest first,
///      ties in triangle index order;
///   3. a candidate is dropped when its point lies on or behind the tangent plane of a contact
///      already accepted: (q - q_a) . n_a <= tol. A point coinciding with an accepted one is the
///      special case q = q_a.
/// Why this is right on flat and convex surfaces: the nearest point of the surface is taken first
/// (a face point if the centre projects into a face; otherwise every triangle around the nearest
/// edge or vertex reports that same point and the nearest of them comes first), and its tangent
/// plane supports the surface there: every other triangle's closest point is on it (flat) or
/// behind it (convex) and is dropped. One contact remains, with the plane's gap and normal on a
/// flat region and (c - q) / |c - q| at a convex edge or vertex, as for the analytic shape.
/// On concave regions (a valley, the inside corner of a box, a floor beside a step) the surface
/// on the other side lies in front of the first tangent plane, so each face the sphere touches
/// keeps its contact, as with the analytic box; a valley line lies in both faces' planes and adds
/// nothing; a convex edge beside a face (a step's rim over a floor) is in front of the floor and
/// kept, because faces go first. Two edge or vertex contacts of distinct features are both kept
/// when each lies in front of the other's tangent plane, which holds unless the two points are
/// closer to each other than the difference of their gaps allows (nearly the same feature).
/// Known limit, shared with all per-triangle schemes: a sphere whose overlap exceeds the local
/// thickness of the part (a thin plate, a wedge sharper than 90 degrees, a centre pushed inside
/// the solid) reaches faces on the other side through the solid and may feel them too. The mesh is
/// two-sided: the normal points from the surface to the centre whatever the triangle's winding,
/// so flipped normals do not change a contact.

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace bondem {

/// A triangle surface: shared vertices, index triples, and one unit normal per triangle (from the
/// winding, right-handed: (v1 - v0) x (v2 - v0)).
struct TriangleMesh {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::array<int, 3>> triangles;
  std::vector<Eigen::Vector3d> normals;  ///< filled by compute_normals
};

/// A flat square plate [lo, hi]^2 at z = 0 of n x n squares, grid line i at lo + (hi - lo) i / n,
/// each square split along its diagonal (i, j)-(i + 1, j + 1), wound counter-clockwise about +z;
/// normals filled. A mesh floor, and the test and benchmark surface of many shared edges.
TriangleMesh tessellated_square(double lo, double hi, int n);

/// Fill mesh.normals from the vertices and the winding. Zero-area triangles get a zero normal
/// (the STL reader drops them before).
void compute_normals(TriangleMesh& mesh);

/// Where on a triangle the closest point lies. Edge k joins vertex k and vertex (k + 1) % 3.
enum class TriangleRegion : std::uint8_t { face, edge0, edge1, edge2, vertex0, vertex1, vertex2 };

/// Whether @p region is the interior of the triangle.
inline bool is_face(TriangleRegion region) {
  return region == TriangleRegion::face;
}
/// Whether @p region is a vertex.
inline bool is_vertex(TriangleRegion region) {
  return region >= TriangleRegion::vertex0;
}

/// Closest point on a triangle and its region.
struct TriangleClosest {
  Eigen::Vector3d point;
  TriangleRegion region;
};

/// Closest point on triangle (@p a, @p b, @p c) to @p p, by the Voronoi-region tests of Ericson,
/// Real-Time Collision Detection, 5.1.5. Points exactly on a region boundary go to the lower-
/// dimensional feature (an edge before the face, a vertex before an edge). The point has the same
/// bits for either winding of the triangle. No allocation.
inline TriangleClosest closest_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                           const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a;
  const Eigen::Vector3d ac = c - a;
  const Eigen::Vector3d ap = p - a;
  const double d1 = ab.dot(ap);
  const double d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return {a, TriangleRegion::vertex0};
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp);
  const double d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return {b, TriangleRegion::vertex1};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    const double v = d1 / (d1 - d3);
    return {a + v * ab, TriangleRegion::edge0};
  }
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp);
  const double d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return {c, TriangleRegion::vertex2};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    const double w = d2 / (d2 - d6);
    return {a + w * ac, TriangleRegion::edge2};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    // Measured from the lexicographically smaller end, so that the reversed winding (a, c, b),
    // which computes the same fractions with the ends swapped, gives the same bits.
    const double sum = (d4 - d3) + (d5 - d6);
    if (std::lexicographical_compare(b.data(), b.data() + 3, c.data(), c.data() + 3)) {
      return {b + ((d4 - d3) / sum) * (c - b), TriangleRegion::edge1};
    }
    return {c + ((d5 - d6) / sum) * (b - c), TriangleRegion::edge1};
  }
  // Grouped so that the reversed winding, which swaps vb and vc, sums the same bits.
  const double denom = 1.0 / (va + (vb + vc));
  const double v = vb * denom;
  const double w = vc * denom;
  return {a + Eigen::Vector3d(ab * v + ac * w), TriangleRegion::face};
}

/// A uniform cell grid over the triangles' bounding boxes: each cell lists (CSR) the triangles
/// whose box meets it. Built once for a mesh at rest in its own frame.
struct TriangleGrid {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  ///< lower corner of cell (0, 0, 0)
  double cell_size = 1.0;
  std::array<int, 3> cells{1, 1, 1};
  std::vector<std::int32_t>
      cell_start;  ///< size cells + 1; triangles of cell k: [start[k], start[k+1])
  std::vector<std::int32_t> cell_triangles;
  std::vector<Eigen::Vector3d> box_min;  ///< per triangle
  std::vector<Eigen::Vector3d> box_max;
  std::vector<std::array<int, 3>> first_cell;  ///< per triangle: its box's lowest cell
};

/// Build the grid over @p mesh with cubic cells of edge @p cell_size (> 0); a good size is about
/// the largest particle diameter or the typical triangle size, whichever is larger. The number of
/// cells is capped (about 2^21) by enlarging the cells.
TriangleGrid build_triangle_grid(const TriangleMesh& mesh, double cell_size);

/// Append to @p out, once each and in no particular order, the triangles whose bounding box the
/// sphere (@p centre, @p radius) reaches into. @p out is the caller's buffer.
void query_triangles(const TriangleGrid& grid, const Eigen::Vector3d& centre, double radius,
                     std::vector<std::int32_t>& out);

/// One contact of a sphere with a mesh.
struct MeshContact {
  Eigen::Vector3d point;   ///< nearest point on the surface
  Eigen::Vector3d normal;  ///< unit, from the surface towards the centre
  double gap =
      0.0;  ///< distance from the centre to point (as SurfacePoint::gap): overlap = r - gap
  std::int32_t triangle = -1;  ///< the triangle the contact was taken from
  TriangleRegion region = TriangleRegion::face;
};

/// Reusable buffers of mesh_contacts: after the first queries no call allocates.
struct MeshQueryBuffer {
  std::vector<std::int32_t> triangles;
  std::vector<MeshContact> candidates;
  std::vector<MeshContact> contacts;
};

/// Relative tolerance of the double-contact rule: a point less than tol = kMeshContactTolerance *
/// radius in front of an accepted contact's tangent plane counts as on it. Round-off
/// of the closest point is about 1e-16 of the coordinates; 1e-9 of a particle radius is far above
/// it for meshes up to 1e5 radii across and far below any geometric feature.
inline constexpr double kMeshContactTolerance = 1.0e-9;

/// The contacts of a sphere (@p centre, @p radius) with @p mesh, one per touched surface feature
/// after the double-contact rule of this file, in its deterministic order (faces, edges, vertices;
/// each nearest first, ties by triangle index). Returns a view of buffer.contacts.
std::span<const MeshContact> mesh_contacts(const TriangleMesh& mesh, const TriangleGrid& grid,
                                           const Eigen::Vector3d& centre, double radius,
                                           MeshQueryBuffer& buffer);

/// A triangle's index with its bounding box, as a Verlet list of triangles stores it: a search
/// through the list then reads its boxes in order instead of gathering them from the mesh.
struct BoxedTriangle {
  double box_min[3];
  double box_max[3];
  std::int32_t triangle;
};

/// The same among @p triangles only (any order, repeats allowed): equal to mesh_contacts whenever
/// @p triangles holds every triangle nearer to @p centre than @p radius, e.g. a list gathered
/// with a larger radius a few steps before (solver/engine/boundary_candidates.hpp).
std::span<const MeshContact> mesh_contacts_among(const TriangleMesh& mesh,
                                                 std::span<const BoxedTriangle> triangles,
                                                 const Eigen::Vector3d& centre, double radius,
                                                 MeshQueryBuffer& buffer);

/// The same without the grid: every triangle is tested (the oracle for the grid in tests).
std::span<const MeshContact> mesh_contacts_brute_force(const TriangleMesh& mesh,
                                                       const Eigen::Vector3d& centre, double radius,
                                                       MeshQueryBuffer& buffer);

}  // namespace bondem
