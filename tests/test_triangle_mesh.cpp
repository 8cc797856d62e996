// Triangle meshes: the closest point on a triangle, the one-contact rule at shared edges and
// vertices, the cell grid against brute force, the STL reader, and the query cost of a
// 100 000-triangle mesh.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "geometry/triangle_mesh.hpp"
#include "io/stl_reader.hpp"
#include "run_helpers.hpp"

namespace bondem {
namespace {

using Eigen::Vector3d;
namespace fs = std::filesystem;

// Round-off of one closest point or plane distance on coordinates of order 1: a few ulps.
constexpr double kRoundOff = 1.0e-14;

TriangleMesh make_mesh(std::vector<Vector3d> vertices, std::vector<std::array<int, 3>> triangles) {
  TriangleMesh mesh{std::move(vertices), std::move(triangles), {}};
  compute_normals(mesh);
  return mesh;
}

// The unit square z = 0 as two triangles split along the diagonal (0,0)-(1,1).
TriangleMesh two_triangle_square() {
  return make_mesh({{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}, {{0, 1, 2}, {0, 2, 3}});
}

// A fan of n triangles around the origin in the plane z = 0 (corners on the unit circle).
TriangleMesh fan(int n) {
  std::vector<Vector3d> vertices{Vector3d::Zero()};
  std::vector<std::array<int, 3>> triangles;
  for (int k = 0; k < n; ++k) {
    const double angle = 2.0 * std::numbers::pi * k / n;
    vertices.emplace_back(std::cos(angle), std::sin(angle), 0.0);
    triangles.push_back({0, 1 + k, 1 + (k + 1) % n});
  }
  return make_mesh(vertices, triangles);
}

// A latitude-longitude sphere of unit radius: convex, with fans of thin triangles at the poles.
TriangleMesh uv_sphere(int slices, int stacks) {
  std::vector<Vector3d> vertices{{0, 0, 1}, {0, 0, -1}};
  for (int s = 1; s < stacks; ++s) {
    const double theta = std::numbers::pi * s / stacks;
    for (int k = 0; k < slices; ++k) {
      const double phi = 2.0 * std::numbers::pi * k / slices;
      vertices.emplace_back(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi),
                            std::cos(theta));
    }
  }
  const auto ring = [&](int s, int k) { return 2 + (s - 1) * slices + (k % slices); };
  std::vector<std::array<int, 3>> triangles;
  for (int k = 0; k < slices; ++k) {
    triangles.push_back({0, ring(1, k), ring(1, k + 1)});
    for (int s = 1; s + 1 < stacks; ++s) {
      triangles.push_back({ring(s, k), ring(s + 1, k), ring(s + 1, k + 1)});
      triangles.push_back({ring(s, k), ring(s + 1, k + 1), ring(s, k + 1)});
    }
    triangles.push_back({1, ring(stacks - 1, k + 1), ring(stacks - 1, k)});
  }
  return make_mesh(vertices, triangles);
}

// Smallest distance from p to any triangle of the mesh.
double nearest_distance(const TriangleMesh& mesh, const Vector3d& p) {
  double best = INFINITY;
  for (const auto& [i, j, k] : mesh.triangles) {
    const TriangleClosest q =
        closest_on_triangle(p, mesh.vertices[i], mesh.vertices[j], mesh.vertices[k]);
    best = std::min(best, (p - q.point).norm());
  }
  return best;
}

TEST(TriangleMesh, ClosestPointInEveryRegion) {
  const Vector3d a(0, 0, 0);
  const Vector3d b(1, 0, 0);
  const Vector3d c(0, 1, 0);
  struct Case {
    Vector3d p;
    Vector3d point;
    TriangleRegion region;
  };
  const Case cases[] = {
      {{0.25, 0.25, 1.0}, {0.25, 0.25, 0.0}, TriangleRegion::face},
      {{0.25, 0.25, -2.0}, {0.25, 0.25, 0.0}, TriangleRegion::face},
      {{0.5, -1.0, 0.5}, {0.5, 0.0, 0.0}, TriangleRegion::edge0},     // a-b
      {{1.0, 1.0, 0.0}, {0.5, 0.5, 0.0}, TriangleRegion::edge1},      // b-c
      {{-1.0, 0.5, 0.3}, {0.0, 0.5, 0.0}, TriangleRegion::edge2},     // c-a
      {{-1.0, -1.0, 2.0}, {0.0, 0.0, 0.0}, TriangleRegion::vertex0},  // a
      {{2.0, -0.5, 0.0}, {1.0, 0.0, 0.0}, TriangleRegion::vertex1},   // b
      {{-0.5, 2.0, -1.0}, {0.0, 1.0, 0.0}, TriangleRegion::vertex2},  // c
      {{0.5, 0.0, 0.7}, {0.5, 0.0, 0.0}, TriangleRegion::edge0},      // right above an edge
      {{0.0, 0.0, 0.7}, {0.0, 0.0, 0.0}, TriangleRegion::vertex0},    // right above a vertex
  };
  for (const Case& k : cases) {
    const TriangleClosest q = closest_on_triangle(k.p, a, b, c);
    EXPECT_EQ(q.region, k.region) << k.p.transpose();
    EXPECT_NEAR((q.point - k.point).norm(), 0.0, kRoundOff) << k.p.transpose();
  }
}

// One contact, with the plane's gap and normal, for a sphere of radius 0.1 at height h over (x, y).
// @p lateral bounds the error of the contact point along the plane (and, divided by h, of the
// normal).
void expect_plane_contact(const TriangleMesh& mesh, double x, double y, double h,
                          double lateral = kRoundOff) {
  const TriangleGrid grid = build_triangle_grid(mesh, 0.25);
  MeshQueryBuffer buffer;
  const auto contacts = mesh_contacts(mesh, grid, {x, y, h}, 0.1, buffer);
  ASSERT_EQ(contacts.size(), 1U) << x << " " << y << " " << h;
  EXPECT_NEAR(contacts[0].gap, std::abs(h), kRoundOff);
  EXPECT_NEAR((contacts[0].normal - Vector3d(0, 0, h > 0 ? 1 : -1)).norm(), 0.0,
              std::max(kRoundOff, lateral / std::abs(h)));
  EXPECT_NEAR((contacts[0].point - Vector3d(x, y, 0)).norm(), 0.0, lateral);
}

TEST(TriangleMesh, FlatSquareOneContactOverTheSharedDiagonal) {
  const TriangleMesh mesh = two_triangle_square();
  for (const double h : {0.05, -0.05, 0.099})
    for (const double s : {0.2, 0.5, 0.8}) expect_plane_contact(mesh, s, s, h);
  // Just off the diagonal either way: one triangle gives the face, the other its diagonal edge.
  for (const double e : {1.0e-13, -1.0e-13, 1.0e-6, -1.0e-6, 0.05, -0.05})
    expect_plane_contact(mesh, 0.5 + e, 0.5, 0.07);
}

TEST(TriangleMesh, FlatFanOneContactOverTheSharedVertex) {
  for (const int n : {4, 8}) {
    const TriangleMesh mesh = fan(n);
    expect_plane_contact(mesh, 0.0, 0.0, 0.05);
    expect_plane_contact(mesh, 0.0, 0.0, -0.08);
    // Around the centre, on the spokes and between them: one contact every time.
    for (int k = 0; k < 32; ++k) {
      const double angle = 2.0 * std::numbers::pi * k / 32;
      for (const double rho : {1.0e-3, 0.05})
        expect_plane_contact(mesh, rho * std::cos(angle), rho * std::sin(angle), 0.06);
      // 1e-12 off the vertex the gaps to the vertex, the spokes and the face agree to the last
      // bit (they differ by rho^2 / 2h = 1e-23), so the nearest is any of them: the gap is
      // exact, the point off by at most rho, the normal by rho / h = 2e-11.
      const double rho = 1.0e-12;
      expect_plane_contact(mesh, rho * std::cos(angle), rho * std::sin(angle), 0.06, rho);
    }
  }
}

// A roof: the ridge x = 0, z = 0 along y in [-1, 1], faces falling by 0.5 per unit of |x|.
TriangleMesh roof(double sign) {
  return make_mesh({{0, -1, 0},
                    {0, 1, 0},
                    {-1, -1, -0.5 * sign},
                    {-1, 1, -0.5 * sign},
                    {1, -1, -0.5 * sign},
                    {1, 1, -0.5 * sign}},
                   {{0, 2, 3}, {0, 3, 1}, {0, 1, 5}, {0, 5, 4}});
}

TEST(TriangleMesh, ConvexEdgeOneContactWithTheEdge) {
  const TriangleMesh mesh = roof(1.0);
  const TriangleGrid grid = build_triangle_grid(mesh, 0.3);
  MeshQueryBuffer buffer;
  // Above the ridge, and tilted towards one face but still in the edge's Voronoi wedge (the face
  // normals lean atan(0.5) = 26.6 degrees, the offset atan(0.2) = 11.3 degrees).
  for (const Vector3d& offset :
       {Vector3d(0, 0, 0.05), Vector3d(0.01, 0, 0.05), Vector3d(-0.01, 0, 0.05)}) {
    const Vector3d centre = Vector3d(0, 0.3, 0) + offset;
    const auto contacts = mesh_contacts(mesh, grid, centre, 0.1, buffer);
    ASSERT_EQ(contacts.size(), 1U) << offset.transpose();
    EXPECT_FALSE(is_face(contacts[0].region));
    EXPECT_NEAR(contacts[0].gap, offset.norm(), kRoundOff);
    EXPECT_NEAR((contacts[0].normal - offset.normalized()).norm(), 0.0, kRoundOff);
    EXPECT_NEAR((contacts[0].point - Vector3d(0, 0.3, 0)).norm(), 0.0, kRoundOff);
  }
  // Over the left face near the ridge: the face alone, the right face's ridge point dropped.
  const Vector3d n_left = Vector3d(-0.5, 0, 1).normalized();
  const Vector3d on_left(-0.02, 0.3, -0.01);
  const auto contacts = mesh_contacts(mesh, grid, on_left + 0.06 * n_left, 0.1, buffer);
  ASSERT_EQ(contacts.size(), 1U);
  EXPECT_TRUE(is_face(contacts[0].region));
  EXPECT_NEAR(contacts[0].gap, 0.06, kRoundOff);
  EXPECT_NEAR((contacts[0].normal - n_left).norm(), 0.0, kRoundOff);
}

TEST(TriangleMesh, ConcaveValleyOneContactPerFace) {
  // The documented concave behaviour: a sphere in a V touches both faces and feels both, as it
  // would two planes; the valley line, in both faces, adds nothing.
  const TriangleMesh mesh = roof(-1.0);
  const TriangleGrid grid = build_triangle_grid(mesh, 0.3);
  MeshQueryBuffer buffer;
  const Vector3d centre(0.0, 0.3, 0.1);
  const auto contacts = mesh_contacts(mesh, grid, centre, 0.1, buffer);
  ASSERT_EQ(contacts.size(), 2U);
  const double gap = 0.1 / Vector3d(0.5, 0, 1).norm();  // height times cos(26.6 degrees)
  for (const MeshContact& c : contacts) {
    EXPECT_TRUE(is_face(c.region));
    EXPECT_NEAR(c.gap, gap, kRoundOff);
  }
  EXPECT_NEAR((contacts[0].normal - Vector3d(0.5, 0, 1).normalized()).norm(), 0.0, kRoundOff);
  EXPECT_NEAR((contacts[1].normal - Vector3d(-0.5, 0, 1).normalized()).norm(), 0.0, kRoundOff);
  // A centre on the valley line itself: every triangle reports the same point, one contact.
  EXPECT_EQ(mesh_contacts(mesh, grid, {0.0, 0.3, 0.0}, 0.05, buffer).size(), 1U);
}

TEST(TriangleMesh, ConvexSphereMeshOneContactWithTheNearestPoint) {
  // Any centre outside a convex polyhedron has one nearest surface point: the rule must find
  // exactly it, whatever face, edge or vertex region it lies in (the poles are vertex fans).
  const TriangleMesh mesh = uv_sphere(24, 12);
  const TriangleGrid grid = build_triangle_grid(mesh, 0.2);
  MeshQueryBuffer buffer;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  int tested = 0;
  for (int k = 0; k < 4000; ++k) {
    Vector3d direction(unit(rng), unit(rng), unit(rng));
    if (k % 10 == 0) direction = Vector3d(0.01 * unit(rng), 0.01 * unit(rng), 1.0);  // pole
    const Vector3d centre = direction.normalized() * (1.0 + 0.05 * (unit(rng) + 1.0));
    // Outside the polyhedron: in front of every face plane it projects into. The inscribed
    // polyhedron is inside the unit sphere, so |centre| > 1 suffices.
    const double radius = 0.15;
    const double nearest = nearest_distance(mesh, centre);
    if (nearest >= radius) continue;
    ++tested;
    const auto contacts = mesh_contacts(mesh, grid, centre, radius, buffer);
    ASSERT_EQ(contacts.size(), 1U) << centre.transpose();
    EXPECT_NEAR(contacts[0].gap, nearest, kRoundOff);
  }
  EXPECT_GT(tested, 3000);
}

TEST(TriangleMesh, TessellatedPlaneAlwaysOneContact) {
  // Random spheres over a 20 x 20 grid of squares, a third of them exactly over edges or vertices.
  const TriangleMesh mesh = tessellated_square(0.0, 1.0, 20);
  const TriangleGrid grid = build_triangle_grid(mesh, 0.05);
  MeshQueryBuffer buffer;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0.1, 0.9);
  std::uniform_int_distribution<int> node(2, 18);
  for (int k = 0; k < 3000; ++k) {
    double x = u(rng);
    double y = u(rng);
    if (k % 3 == 1) x = node(rng) / 20.0;  // on a grid line
    if (k % 6 == 2) y = node(rng) / 20.0;  // and on a vertex
    if (k % 9 == 3) y = x;                 // a diagonal
    const double h = 0.001 + 0.07 * (u(rng) - 0.1);
    const auto contacts = mesh_contacts(mesh, grid, {x, y, h}, 0.08, buffer);
    ASSERT_EQ(contacts.size(), 1U) << x << " " << y << " " << h;
    EXPECT_NEAR(contacts[0].gap, h, kRoundOff);
    EXPECT_NEAR((contacts[0].normal - Vector3d::UnitZ()).norm(), 0.0, kRoundOff);
  }
}

TEST(TriangleMesh, GridQueriesEqualBruteForce) {
  // The same contacts (triangle, region, bitwise point and normal) for random spheres, with
  // cells smaller than, about equal to and larger than the triangles; the triangle lists hold
  // every triangle whose box the sphere reaches into, once.
  TriangleMesh mesh = uv_sphere(32, 16);
  for (Vector3d& v : mesh.vertices)
    v = Vector3d(1.5 * v.x(), v.y(), 0.7 * v.z()) + Vector3d(3, -2, 1);
  compute_normals(mesh);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (const double cell : {0.03, 0.2, 1.0, 10.0}) {
    const TriangleGrid grid = build_triangle_grid(mesh, cell);
    MeshQueryBuffer fast;
    MeshQueryBuffer slow;
    std::vector<std::int32_t> listed;
    int touching = 0;
    for (int k = 0; k < 2000; ++k) {
      const Vector3d centre =
          Vector3d(3, -2, 1) + Vector3d(1.8 * unit(rng), 1.2 * unit(rng), 1.0 * unit(rng));
      const double radius = 0.02 + 0.2 * (unit(rng) + 1.0);
      const auto a = mesh_contacts(mesh, grid, centre, radius, fast);
      const auto b = mesh_contacts_brute_force(mesh, centre, radius, slow);
      ASSERT_EQ(a.size(), b.size());
      touching += a.empty() ? 0 : 1;
      for (std::size_t c = 0; c < a.size(); ++c) {
        EXPECT_EQ(a[c].triangle, b[c].triangle);
        EXPECT_EQ(a[c].region, b[c].region);
        EXPECT_EQ(a[c].point, b[c].point);
        EXPECT_EQ(a[c].normal, b[c].normal);
        EXPECT_EQ(a[c].gap, b[c].gap);
      }
      listed.clear();
      query_triangles(grid, centre, radius, listed);
      std::sort(listed.begin(), listed.end());
      std::vector<std::int32_t> expected;
      for (std::int32_t t = 0; t < static_cast<std::int32_t>(mesh.triangles.size()); ++t)
        if ((centre - centre.cwiseMax(grid.box_min[t]).cwiseMin(grid.box_max[t])).squaredNorm() <
            radius * radius)
          expected.push_back(t);
      ASSERT_EQ(listed, expected) << "cell " << cell;
    }
    EXPECT_GT(touching, 500) << "cell " << cell;
  }
}

// --- STL reader ------------------------------------------------------------------------------

// The unit cube [0, 1]^3, 12 facets wound outward.
std::vector<std::array<Vector3d, 3>> cube_facets() {
  const auto p = [](int bits) {
    return Vector3d(bits & 1 ? 1.0 : 0.0, bits & 2 ? 1.0 : 0.0, bits & 4 ? 1.0 : 0.0);
  };
  // Each face as a quad (corners counter-clockwise seen from outside) split in two.
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                           {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  std::vector<std::array<Vector3d, 3>> facets;
  for (const auto& q : quads) {
    facets.push_back({p(q[0]), p(q[1]), p(q[2])});
    facets.push_back({p(q[0]), p(q[2]), p(q[3])});
  }
  return facets;
}

fs::path stl_path(const std::string& name) {
  const fs::path directory = testing::test_root() / "bondem_stl";
  fs::create_directories(directory);
  return directory / name;
}

fs::path write_ascii_stl(const std::string& name,
                         const std::vector<std::array<Vector3d, 3>>& facets) {
  fs::path path = stl_path(name);
  std::ofstream out(path);
  out << "solid cube\n";
  for (const auto& f : facets) {
    out << "  facet normal 0 0 0\n    outer loop\n";
    for (const Vector3d& v : f)
      out << "      vertex " << v.x() << " " << v.y() << " " << v.z() << "\n";
    out << "    endloop\n  endfacet\n";
  }
  out << "endsolid cube\n";
  return path;
}

fs::path write_binary_stl(const std::string& name,
                          const std::vector<std::array<Vector3d, 3>>& facets) {
  fs::path path = stl_path(name);
  std::ofstream out(path, std::ios::binary);
  // A header beginning with "solid", as some exporters write: the size decides, not the text.
  std::string header = "solid binary cube";
  header.resize(80, ' ');
  out.write(header.data(), 80);
  const auto count = static_cast<std::uint32_t>(facets.size());
  const unsigned char le[4] = {static_cast<unsigned char>(count & 0xFFU),
                               static_cast<unsigned char>((count >> 8U) & 0xFFU),
                               static_cast<unsigned char>((count >> 16U) & 0xFFU),
                               static_cast<unsigned char>((count >> 24U) & 0xFFU)};
  out.write(reinterpret_cast<const char*>(le), 4);
  for (const auto& f : facets) {
    float values[12] = {};
    for (int v = 0; v < 3; ++v)
      for (int axis = 0; axis < 3; ++axis)
        values[3 + 3 * v + axis] = static_cast<float>(f[v][axis]);
    out.write(reinterpret_cast<const char*>(values), sizeof(values));
    const char attribute[2] = {0, 0};
    out.write(attribute, 2);
  }
  return path;
}

void expect_cube(const StlMesh& read, double scale, const Vector3d& offset) {
  const TriangleMesh& mesh = read.mesh;
  EXPECT_EQ(read.facets_in_file, 12);
  EXPECT_EQ(read.dropped_degenerate, 0);
  ASSERT_EQ(mesh.triangles.size(), 12U);
  EXPECT_EQ(mesh.vertices.size(), 8U);  // merged: each corner is shared by 3 to 6 facets
  Vector3d lo = mesh.vertices[0];
  Vector3d hi = mesh.vertices[0];
  for (const Vector3d& v : mesh.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  // Exact: the corners are 0 and 1 (in float too), scale and offset are exact in binary.
  EXPECT_EQ(lo, offset);
  EXPECT_EQ(hi, offset + Vector3d::Constant(scale));
  // Normals from the winding point outward: from the cube's centre towards the facet.
  const Vector3d middle = offset + Vector3d::Constant(0.5 * scale);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    EXPECT_NEAR(mesh.normals[t].norm(), 1.0, kRoundOff);
    EXPECT_GT((mesh.vertices[mesh.triangles[t][0]] - middle).dot(mesh.normals[t]), 0.0);
  }
}

TEST(StlReader, AsciiAndBinaryCube) {
  const fs::path ascii = write_ascii_stl("cube_ascii.stl", cube_facets());
  const fs::path binary = write_binary_stl("cube_binary.stl", cube_facets());
  expect_cube(read_stl(ascii), 1.0, Vector3d::Zero());
  expect_cube(read_stl(binary), 1.0, Vector3d::Zero());
  expect_cube(read_stl(ascii, 2.0, {1.0, -2.0, 0.5}), 2.0, {1.0, -2.0, 0.5});
  expect_cube(read_stl(binary, 0.25, {1.0, -2.0, 0.5}), 0.25, {1.0, -2.0, 0.5});
}

std::string stl_error(const fs::path& path, double scale = 1.0) {
  try {
    read_stl(path, scale);
  } catch (const StlError& e) {
    return e.what();
  }
  return "";
}

void write_bytes(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out << bytes;
}

TEST(StlReader, ClearErrorsNamingTheFile) {
  const fs::path missing = stl_path("missing.stl");
  fs::remove(missing);
  EXPECT_EQ(stl_error(missing), missing.string() + ": no such file");

  const fs::path empty = stl_path("empty.stl");
  write_bytes(empty, "");
  EXPECT_EQ(stl_error(empty), empty.string() + ": empty file, not an STL mesh");

  const fs::path text = stl_path("garbage.stl");
  write_bytes(text, "name,x,y\nblade,1,2\n");
  EXPECT_NE(stl_error(text).find(text.string() + ": not an STL file"), std::string::npos);

  const fs::path binary_garbage = stl_path("garbage.bin.stl");
  write_bytes(binary_garbage, std::string(200, '\x07'));  // not 84 + 50 n bytes, not "solid"
  EXPECT_NE(stl_error(binary_garbage).find(": not an STL file"), std::string::npos);

  const fs::path no_facets = stl_path("no_facets.stl");
  write_bytes(no_facets, "solid nothing\nendsolid nothing\n");
  EXPECT_EQ(stl_error(no_facets), no_facets.string() + ": ASCII STL with no facets");

  const fs::path binary_none = write_binary_stl("binary_none.stl", {});
  EXPECT_EQ(stl_error(binary_none), binary_none.string() + ": binary STL with no facets");

  const fs::path cube = write_ascii_stl("cube_for_scale.stl", cube_facets());
  EXPECT_EQ(stl_error(cube, -1.0), cube.string() + ": scale must be a positive number");
  EXPECT_EQ(stl_error(cube, 0.0), cube.string() + ": scale must be a positive number");
}

TEST(StlReader, DegenerateFacetsDroppedAndCountedOrRefused) {
  // A cube plus a facet with two equal corners and one with collinear corners: both dropped.
  std::vector<std::array<Vector3d, 3>> facets = cube_facets();
  facets.push_back({Vector3d(0, 0, 0), Vector3d(1, 0, 0), Vector3d(1, 0, 0)});
  facets.push_back({Vector3d(0, 0, 0), Vector3d(0.5, 0, 0), Vector3d(1, 0, 0)});
  for (const fs::path& path : {write_ascii_stl("cube_slivers.stl", facets),
                               write_binary_stl("cube_slivers_bin.stl", facets)}) {
    const StlMesh read = read_stl(path);
    EXPECT_EQ(read.facets_in_file, 14);
    EXPECT_EQ(read.dropped_degenerate, 2);
    EXPECT_EQ(read.mesh.triangles.size(), 12U);
  }
  // Nothing but slivers: refused.
  const fs::path slivers =
      write_binary_stl("slivers.stl", {{Vector3d(0, 0, 0), Vector3d(1, 0, 0), Vector3d(2, 0, 0)},
                                       {Vector3d(0, 1, 0), Vector3d(0, 1, 0), Vector3d(0, 2, 0)}});
  EXPECT_EQ(stl_error(slivers),
            slivers.string() + ": no facet with a non-zero area (2 degenerate)");
}

TriangleMesh mesh_of(const std::vector<std::array<Vector3d, 3>>& facets) {
  TriangleMesh mesh;
  for (const auto& f : facets) {
    const int first = static_cast<int>(mesh.vertices.size());
    mesh.vertices.insert(mesh.vertices.end(), f.begin(), f.end());
    mesh.triangles.push_back({first, first + 1, first + 2});
  }
  compute_normals(mesh);
  return mesh;
}

TEST(TriangleMesh, InsideCornerOfAMeshBoxEqualsTheAnalyticBox) {
  // Inside the unit cube near the corner at the origin: three faces, three contacts with the
  // box's gaps and inward normals; the cube's edges and corner add nothing. (0.05, 0.05, 0.05)
  // projects onto the split diagonal of all three faces (edge regions only).
  const TriangleMesh mesh = mesh_of(cube_facets());
  const TriangleGrid grid = build_triangle_grid(mesh, 0.5);
  MeshQueryBuffer buffer;
  for (const Vector3d& centre : {Vector3d(0.05, 0.06, 0.07), Vector3d(0.05, 0.05, 0.05)}) {
    const auto contacts = mesh_contacts(mesh, grid, centre, 0.1, buffer);
    ASSERT_EQ(contacts.size(), 3U) << centre.transpose();
    std::array<bool, 3> seen{};
    for (const MeshContact& c : contacts) {
      Eigen::Index axis = 0;
      c.normal.cwiseAbs().maxCoeff(&axis);
      seen[axis] = true;
      EXPECT_NEAR(c.gap, centre[axis], kRoundOff);
      EXPECT_NEAR((c.normal - Vector3d::Unit(axis)).norm(), 0.0, kRoundOff);
    }
    EXPECT_TRUE(seen[0] && seen[1] && seen[2]);
  }
}

TEST(TriangleMesh, FloorBesideAStepRimTwoContacts) {
  // A floor z = 0 (x > 0) meets a step 0.05 high (x < 0): a sphere over the floor close to the
  // step touches the floor and the step's convex rim; both are kept (faces go first, and the rim
  // is in front of the floor's plane), the rim once although four triangles report it.
  const auto quad = [](Vector3d a, Vector3d b, Vector3d c, Vector3d d) {
    return std::vector<std::array<Vector3d, 3>>{{a, b, c}, {a, c, d}};
  };
  std::vector<std::array<Vector3d, 3>> facets;
  for (const auto& q : {quad({0, -1, 0}, {2, -1, 0}, {2, 1, 0}, {0, 1, 0}),
                        quad({0, -1, 0}, {0, 1, 0}, {0, 1, 0.05}, {0, -1, 0.05}),
                        quad({-1, -1, 0.05}, {0, -1, 0.05}, {0, 1, 0.05}, {-1, 1, 0.05})})
    facets.insert(facets.end(), q.begin(), q.end());
  const TriangleMesh mesh = mesh_of(facets);
  const TriangleGrid grid = build_triangle_grid(mesh, 0.2);
  MeshQueryBuffer buffer;
  const Vector3d centre(0.02, 0.3, 0.09);
  const auto contacts = mesh_contacts(mesh, grid, centre, 0.1, buffer);
  ASSERT_EQ(contacts.size(), 2U);
  EXPECT_TRUE(is_face(contacts[0].region));
  EXPECT_NEAR(contacts[0].gap, 0.09, kRoundOff);
  const Vector3d to_rim = centre - Vector3d(0, 0.3, 0.05);
  EXPECT_FALSE(is_face(contacts[1].region));
  EXPECT_NEAR(contacts[1].gap, to_rim.norm(), kRoundOff);
  EXPECT_NEAR((contacts[1].normal - to_rim.normalized()).norm(), 0.0, kRoundOff);
}

TEST(TriangleMesh, FlippedWindingGivesTheSameContacts) {
  // The mesh is two-sided: the normal points from the surface to the centre whatever the winding.
  const TriangleMesh mesh = uv_sphere(16, 8);
  TriangleMesh flipped = mesh;
  for (auto& t : flipped.triangles) std::swap(t[1], t[2]);
  compute_normals(flipped);
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  MeshQueryBuffer a_buffer;
  MeshQueryBuffer b_buffer;
  int touching = 0;
  for (int k = 0; k < 2000; ++k) {
    const Vector3d centre =
        Vector3d(unit(rng), unit(rng), unit(rng)).normalized() * (1.0 + 0.2 * unit(rng));
    const auto a = mesh_contacts_brute_force(mesh, centre, 0.25, a_buffer);
    const auto b = mesh_contacts_brute_force(flipped, centre, 0.25, b_buffer);
    ASSERT_EQ(a.size(), b.size());
    touching += a.empty() ? 0 : 1;
    for (std::size_t c = 0; c < a.size(); ++c) {
      // The triangle may differ: at a shared edge or vertex the neighbours' gaps agree to
      // round-off, which the swapped corners change.
      EXPECT_NEAR((a[c].point - b[c].point).norm(), 0.0, kRoundOff);
      // An edge or vertex normal is (c - q) / gap: the point's round-off divided by the gap.
      EXPECT_NEAR((a[c].normal - b[c].normal).norm(), 0.0, kRoundOff * (1.0 + 1.0 / a[c].gap));
      EXPECT_NEAR(a[c].gap, b[c].gap, kRoundOff);
    }
  }
  EXPECT_GT(touching, 1500);
}

// --- cost ------------------------------------------------------------------------------------

TEST(TriangleMesh, QueryCostOfA100kTrianglePlane) {
  // 224 x 224 squares = 100 352 triangles of 4.5 mm over a 1 m plate; spheres of radius 1 mm
  // within one radius of it (each touches it). Printed, not asserted: the machine is shared.
  const int n = 224;
  const TriangleMesh mesh = tessellated_square(0.0, 1.0, n);
  ASSERT_EQ(mesh.triangles.size(), 100352U);
  const auto t0 = std::chrono::steady_clock::now();
  const TriangleGrid grid = build_triangle_grid(mesh, 1.0 / n);
  const auto t1 = std::chrono::steady_clock::now();
  const double radius = 1.0e-3;
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.01, 0.99);
  std::vector<Vector3d> centres;
  centres.reserve(200000);
  for (int k = 0; k < 200000; ++k) centres.emplace_back(u(rng), u(rng), radius * u(rng));
  MeshQueryBuffer buffer;
  std::size_t contacts = 0;
  const auto t2 = std::chrono::steady_clock::now();
  for (const Vector3d& c : centres) contacts += mesh_contacts(mesh, grid, c, radius, buffer).size();
  const auto t3 = std::chrono::steady_clock::now();
  // The analytic plane z = 0 for the same spheres, as the yardstick.
  std::size_t plane_contacts = 0;
  double sink = 0.0;
  for (const Vector3d& c : centres) {
    if (c.z() < radius) {
      ++plane_contacts;
      sink += c.z();
    }
  }
  const auto t4 = std::chrono::steady_clock::now();
  // In a run the particles are sorted by cell: the same spheres in row order.
  std::sort(centres.begin(), centres.end(), [n](const Vector3d& a, const Vector3d& b) {
    const auto row_a = static_cast<int>(a.y() * n);
    const auto row_b = static_cast<int>(b.y() * n);
    return row_a != row_b ? row_a < row_b : a.x() < b.x();
  });
  std::size_t sorted_contacts = 0;
  const auto t5 = std::chrono::steady_clock::now();
  for (const Vector3d& c : centres)
    sorted_contacts += mesh_contacts(mesh, grid, c, radius, buffer).size();
  const auto t6 = std::chrono::steady_clock::now();
  EXPECT_EQ(sorted_contacts, centres.size());
  EXPECT_EQ(contacts, centres.size());
  EXPECT_EQ(plane_contacts, centres.size());
  const auto queries = static_cast<double>(centres.size());
  const auto seconds = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
  std::printf(
      "100352-triangle plane: grid build %.1f ms (%d x %d x %d cells, %zu entries); "
      "%.0f ns per sphere query, %.2e contacts/s (spheres sorted by row: %.0f ns); analytic "
      "plane %.1f ns per sphere (sink %g)\n",
      1e3 * seconds(t0, t1), grid.cells[0], grid.cells[1], grid.cells[2],
      grid.cell_triangles.size(), 1e9 * seconds(t2, t3) / queries,
      static_cast<double>(contacts) / seconds(t2, t3), 1e9 * seconds(t5, t6) / queries,
      1e9 * seconds(t3, t4) / queries, sink);
}

}  // namespace
}  // namespace bondem
