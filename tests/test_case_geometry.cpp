// The STL geometry shipped with the cases (cases/geometry/, written by scripts/make-geometry.py),
// read back through read_stl: triangle counts, bounding boxes, closed and consistently wound
// surfaces, and enclosed volumes against the polygon areas of the tessellated profiles.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <numbers>
#include <string>
#include <utility>

#include "io/stl_reader.hpp"

namespace bondem {
namespace {

using Eigen::Vector3d;

// STL stores float32 coordinates (VTK's reader keeps them as float), so every vertex sits within
// 2^-24 of its own size of the generator's double. A volume moves by at most (largest vertex
// shift) x (area of the surface whose vertices shift). The drum: rim points of radius R shift by
// up to sqrt(2) R 2^-24, which changes the 96-gon's area A ~ pi R^2 by at most its perimeter
// 2 pi R times that, a relative 2 sqrt(2) 2^-24; the blade's only inexact points are the 16 arc
// points, far less. Hence 4 x 2^-24 relative. The test can tell the tessellated solids from the
// smooth ones: those differ by 2.6e-5 (blade) and 7.1e-4 (drum) relative.
constexpr double kFloatVolume = 4.0 * 0x1.0p-24;
// Bounding-box corners are exact in float (-5, -2, -1, 0, 1, 2, 5, 6).
constexpr double kBox = 1.0e-9;

std::string geometry(const std::string& name) {
  return std::string(BONDEM_CASES_DIR) + "/geometry/" + name;
}

struct Box {
  Vector3d lo, hi;
};

Box bounding_box(const TriangleMesh& mesh) {
  Box box{mesh.vertices.at(0), mesh.vertices.at(0)};
  for (const Vector3d& v : mesh.vertices) {
    box.lo = box.lo.cwiseMin(v);
    box.hi = box.hi.cwiseMax(v);
  }
  return box;
}

void expect_box(const TriangleMesh& mesh, const Vector3d& lo, const Vector3d& hi) {
  const Box box = bounding_box(mesh);
  const double size = (hi - lo).norm();
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_NEAR(box.lo[axis], lo[axis], kBox * size) << "axis " << axis;
    EXPECT_NEAR(box.hi[axis], hi[axis], kBox * size) << "axis " << axis;
  }
}

// Closed and consistently wound: every directed edge (a, b) occurs exactly once and its reverse
// (b, a) exactly once, so every edge is shared by exactly two triangles that traverse it in
// opposite senses. Returns the number of undirected edges (0 on failure, with the failures
// reported).
std::size_t closed_edges(const TriangleMesh& mesh) {
  std::map<std::pair<int, int>, int> directed;
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) ++directed[{t[k], t[(k + 1) % 3]}];
  std::size_t failures = 0;
  for (const auto& [edge, count] : directed) {
    const auto reverse = directed.find({edge.second, edge.first});
    const int reverse_count = reverse == directed.end() ? 0 : reverse->second;
    if (count != 1 || reverse_count != 1) {
      ++failures;
      ADD_FAILURE() << "edge " << edge.first << "-" << edge.second << " used " << count
                    << " times, its reverse " << reverse_count << " times";
    }
  }
  return failures == 0 ? directed.size() / 2 : 0;
}

// Volume enclosed by a closed surface by the divergence theorem: the sum of the signed volumes of
// the tetrahedra (origin, a, b, c); positive when the normals point outward.
double signed_volume(const TriangleMesh& mesh) {
  double six_volume = 0.0;
  for (const auto& t : mesh.triangles)
    six_volume += mesh.vertices[t[0]].dot(mesh.vertices[t[1]].cross(mesh.vertices[t[2]]));
  return six_volume / 6.0;
}

TEST(CaseGeometry, ProfiledBladeIsAClosedOutwardSolid) {
  const StlMesh read = read_stl(geometry("profiled_blade.stl"));
  const TriangleMesh& mesh = read.mesh;
  constexpr int kArcSegments = 16;
  constexpr double kEdgeRadius = 0.5;
  // Outline: 2 back corners, 17 arc points (the bottom and front faces start at its ends), the
  // top front corner: 20 points. Mantle 2 x 20, caps fanned from a corner 2 x (20 - 2).
  constexpr int kOutline = 3 + kArcSegments + 1;
  EXPECT_EQ(read.facets_in_file, 2 * kOutline + 2 * (kOutline - 2));
  EXPECT_EQ(read.dropped_degenerate, 0);
  ASSERT_EQ(mesh.triangles.size(), 76U);
  EXPECT_EQ(mesh.vertices.size(), static_cast<std::size_t>(2 * kOutline));  // merged by the reader
  expect_box(mesh, {-1.0, -2.0, 0.0}, {1.0, 2.0, 6.0});

  const std::size_t edges = closed_edges(mesh);
  ASSERT_EQ(edges, 3 * mesh.triangles.size() / 2);
  // A closed surface of genus 0 (a solid without holes): V - E + F = 2.
  EXPECT_EQ(static_cast<long>(mesh.vertices.size()) - static_cast<long>(edges) +
                static_cast<long>(mesh.triangles.size()),
            2);

  // Profile area: 2 x 6 minus the corner square r^2, plus the polygonal quarter disk (16
  // isosceles triangles of apex angle (pi/2)/16 about the arc centre). Times the length 4.
  const double area = 2.0 * 6.0 - kEdgeRadius * kEdgeRadius +
                      kArcSegments * 0.5 * kEdgeRadius * kEdgeRadius *
                          std::sin(0.5 * std::numbers::pi / kArcSegments);
  const double volume = area * 4.0;
  EXPECT_NEAR(signed_volume(mesh), volume, kFloatVolume * volume);  // positive: outward

  // The blade is convex, so outward also holds facet by facet: seen from a point inside.
  const Vector3d inside(0.0, 0.0, 3.0);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    EXPECT_GT((mesh.vertices[mesh.triangles[t][0]] - inside).dot(mesh.normals[t]), 0.0) << t;
}

TEST(CaseGeometry, DrumIsAClosedInwardCylinder) {
  const StlMesh read = read_stl(geometry("drum.stl"));
  const TriangleMesh& mesh = read.mesh;
  constexpr int kSegments = 96;
  constexpr double kRadius = 5.0;
  constexpr double kLength = 2.0;
  // Mantle 2 x 96, two end disks of 96 fan triangles.
  EXPECT_EQ(read.facets_in_file, 4 * kSegments);
  EXPECT_EQ(read.dropped_degenerate, 0);
  ASSERT_EQ(mesh.triangles.size(), 384U);
  EXPECT_EQ(mesh.vertices.size(), static_cast<std::size_t>(2 * kSegments + 2));
  expect_box(mesh, {-kRadius, -0.5 * kLength, -kRadius}, {kRadius, 0.5 * kLength, kRadius});

  const std::size_t edges = closed_edges(mesh);
  ASSERT_EQ(edges, 3 * mesh.triangles.size() / 2);
  EXPECT_EQ(static_cast<long>(mesh.vertices.size()) - static_cast<long>(edges) +
                static_cast<long>(mesh.triangles.size()),
            2);

  // The 96-gon of circumradius R: 96 triangles of apex angle 2 pi / 96. Negative: the normals
  // point into the drum.
  const double volume =
      0.5 * kSegments * kRadius * kRadius * std::sin(2.0 * std::numbers::pi / kSegments) * kLength;
  EXPECT_NEAR(signed_volume(mesh), -volume, kFloatVolume * volume);

  // Facet by facet: every normal faces the drum's centre (the drum is convex).
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    EXPECT_LT(mesh.vertices[mesh.triangles[t][0]].dot(mesh.normals[t]), 0.0) << t;
}

}  // namespace
}  // namespace bondem
