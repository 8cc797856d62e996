// Triangle-mesh boundaries in stepped scenes, against the analytic shapes they imitate: a sphere
// on a flat mesh moves as on a plane (resting, sliding, rolling, held by static friction across
// edges and vertices), in a mesh box corner as in a box container, on a convex mesh edge as on a
// box edge; flipped windings change nothing; moving meshes' loads balance the particles'
// momentum; runs with moving meshes are the same bytes at 1 and 2 threads and after a restart.
#include <gtest/gtest.h>
#include <omp.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <functional>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "geometry/boundary.hpp"
#include "geometry/triangle_mesh.hpp"
#include "run_helpers.hpp"
#include "scene_builders.hpp"
#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"
#include "solver/models/pair.hpp"

namespace bondem {
namespace {

using Eigen::Vector3d;

constexpr double kG = 9.81;
constexpr double kRadius = 1e-3;
constexpr double kYoungs = 1e8;
constexpr double kPoisson = 0.3;

// --- meshes ------------------------------------------------------------------------------------

TriangleMesh make_mesh(std::vector<Vector3d> vertices, std::vector<std::array<int, 3>> triangles) {
  TriangleMesh mesh{std::move(vertices), std::move(triangles), {}};
  compute_normals(mesh);
  return mesh;
}

/// Coordinate of grid line @p i of @p n over [lo, hi]: tessellated_square's expression, so that
/// particles placed on a line sit exactly on its vertices' line.
double grid_line(double lo, double hi, int n, int i) {
  return lo + (hi - lo) * i / n;
}

/// The box [lo, hi], 12 triangles wound outward (two per face).
TriangleMesh cube_mesh(const Vector3d& lo, const Vector3d& hi) {
  std::vector<Vector3d> vertices;
  vertices.reserve(8);
  for (int bits = 0; bits < 8; ++bits) {
    vertices.emplace_back(bits & 1 ? hi.x() : lo.x(), bits & 2 ? hi.y() : lo.y(),
                          bits & 4 ? hi.z() : lo.z());
  }
  constexpr int kQuads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  std::vector<std::array<int, 3>> triangles;
  for (const auto& q : kQuads) {
    triangles.push_back({q[0], q[1], q[2]});
    triangles.push_back({q[0], q[2], q[3]});
  }
  return make_mesh(vertices, triangles);
}

/// @p mesh with every triangle's winding reversed (normals flipped).
TriangleMesh flipped(TriangleMesh mesh) {
  for (auto& t : mesh.triangles) std::swap(t[1], t[2]);
  compute_normals(mesh);
  return mesh;
}

// --- cases and runs ----------------------------------------------------------------------------

/// One sphere (r = 1 mm, E = 100 MPa, rho = 2500) with contact damping 0.3, gravity -z, no
/// boundary yet. dt = 1 us resolves the contact (period about 0.5 ms) by some 500 steps.
Case one_sphere(const Vector3d& position, double friction, double rolling_friction) {
  Case c = testing::soft_case(0.3);
  c.materials[0].youngs_modulus = kYoungs;
  c.contact.friction = friction;
  c.contact.rolling_friction = rolling_friction;
  c.gravity = Vector3d(0.0, 0.0, -kG);
  ParticleSpec p;
  p.radius = kRadius;
  p.position = position;
  c.particles.push_back(p);
  Domain d;
  d.min = Vector3d::Constant(-0.01);
  d.max = Vector3d::Constant(0.01);
  c.domain = d;
  c.time_step = 1e-6;
  return c;
}

/// Floor z = 0 as a plane, or as @p mesh (vertices in world coordinates, reference point 0).
Boundary floor_plane() {
  return plane_boundary(Vector3d::Zero(), Vector3d::UnitZ(), 0, "floor");
}
Boundary floor_mesh(TriangleMesh mesh) {
  return mesh_boundary(std::move(mesh), Vector3d::Zero(), 0, "floor");
}

/// Weight of the sphere and its Hertz overlap under it on a wall of the same material (r* = r).
double weight() {
  return sphere_mass(kRadius, 2500.0) * kG;
}
double hertz_overlap(double load) {
  const double k =
      hertz_stiffness(effective_modulus(kYoungs, kPoisson, kYoungs, kPoisson), kRadius);
  return std::pow(load / k, 2.0 / 3.0);
}

/// Per step (after each): particle 0's position, velocity, spin and force, the boundary contacts,
/// and the load summed over all boundaries.
struct Track {
  std::vector<Vector3d> x, v, w, f, load;
  std::vector<std::size_t> contacts;

  bool operator==(const Track& o) const {
    return x == o.x && v == o.v && w == o.w && f == o.f && load == o.load && contacts == o.contacts;
  }
};

Track run_track(const Case& c, int steps, const std::function<void(Scene&)>& prepare = {}) {
  Scene scene = build_scene(c);
  if (prepare) prepare(scene);
  Stepper stepper(scene);
  const Particles& p = scene.particles;
  Track t;
  for (int s = 0; s < steps; ++s) {
    stepper.step();
    t.x.emplace_back(p.x[0], p.y[0], p.z[0]);
    t.v.emplace_back(p.vx[0], p.vy[0], p.vz[0]);
    t.w.emplace_back(p.wx[0], p.wy[0], p.wz[0]);
    t.f.emplace_back(p.fx[0], p.fy[0], p.fz[0]);
    Vector3d load = Vector3d::Zero();
    for (const BoundaryLoad& b : stepper.boundary_loads()) {
      load += b.force;
    }
    t.load.push_back(load);
    t.contacts.push_back(stepper.contacts().wall_contacts);
  }
  return t;
}

/// Largest |a[k] - b[k]| over a history.
double worst(const std::vector<Vector3d>& a, const std::vector<Vector3d>& b) {
  double w = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k) w = std::max(w, (a[k] - b[k]).norm());
  return w;
}

// --- 1. resting on a two-triangle square -----------------------------------------------------

TEST(MeshFloor, SphereOnATwoTriangleSquareCarriesItsWeightAsOnAPlane) {
  // The square [-2, 2] mm^2 split along its diagonal y = x; the sphere stands off the diagonal,
  // in one triangle's face region, at the closed-form Hertz overlap under its weight.
  const TriangleMesh square = tessellated_square(-0.002, 0.002, 1);
  const double w = weight();
  const Vector3d at(0.5e-3, -0.3e-3, kRadius - hertz_overlap(w));
  Case on_plane = one_sphere(at, 0.3, 0.0);
  on_plane.boundaries.push_back(floor_plane());
  Case on_mesh = one_sphere(at, 0.3, 0.0);
  on_mesh.boundaries.push_back(floor_mesh(square));
  Scene plane_scene = build_scene(on_plane);
  Scene mesh_scene = build_scene(on_mesh);
  const Stepper plane_stepper(plane_scene);
  const Stepper mesh_stepper(mesh_scene);
  const Vector3d load = mesh_stepper.boundary_loads()[0].force;
  // The overlap is r - z with z = r - delta: the cancellation leaves delta uncertain by an ulp of
  // r (2.2e-19 m) in 1.25e-7 m, 1.7e-12, the force by 1.5 times that; 1e-11 of W bounds it.
  EXPECT_NEAR(load.z(), -w, 1e-11 * w);
  EXPECT_EQ(load.x(), 0.0);
  EXPECT_EQ(load.y(), 0.0);
  EXPECT_EQ(mesh_stepper.contacts().wall_contacts, 1U);
  // A face region's gap is the plane distance (c - a) . n with n = (0, 0, 1) exactly, the same
  // products and sums as the plane's: the same bits.
  EXPECT_EQ(load, plane_stepper.boundary_loads()[0].force);
  EXPECT_EQ(mesh_scene.particles.fz[0], plane_scene.particles.fz[0]);

  // Dropped from 20 um with a sideways drift and friction: it bounces, slides, rolls and settles,
  // all in that face region, so the whole trajectory is bit for bit the plane's.
  const Vector3d drop(0.5e-3, -0.3e-3, kRadius + 20e-6);
  for (Case* c : {&on_plane, &on_mesh}) {
    c->particles.edit(0).position = drop;
    c->particles.edit(0).velocity = Vector3d(0.01, 0.0, 0.0);
  }
  const Track plane = run_track(on_plane, 15000);
  const Track mesh = run_track(on_mesh, 15000);
  EXPECT_TRUE(mesh == plane) << "worst z difference " << worst(mesh.x, plane.x);
  // Settled: the first touch is at 2 ms, and the contact damping's e-folding time 1 / (xi omega)
  // is 0.3 ms.
  EXPECT_NEAR(mesh.load.back().z(), -w, 1e-6 * w);
  EXPECT_EQ(mesh.contacts.back(), 1U);
  EXPECT_GT(mesh.x.back().x(), drop.x() + 1e-5);  // it drifted on the face

  // Right over the diagonal (x = y exactly) each triangle reports its diagonal edge: the gap is
  // |c - q| with q on the edge off by round-off of the coordinates (1e-19 m), which changes the
  // gap not at all (the error enters squared) and tilts the normal by 1e-19 / 1e-3 = 1e-16; the
  // trajectory then differs from the plane's by that relative amount per step. 1e-12 of the
  // impact speed (0.02 m/s) bounds 1e4 steps of such tilts with a margin of 1e2 (measured:
  // 4e-17 m/s, 0 m).
  const Vector3d diagonal(0.4e-3, 0.4e-3, kRadius + 20e-6);
  for (Case* c : {&on_plane, &on_mesh}) {
    c->particles.edit(0).position = diagonal;
    c->particles.edit(0).velocity = Vector3d::Zero();
  }
  const Track plane_diagonal = run_track(on_plane, 15000);
  const Track mesh_diagonal = run_track(on_mesh, 15000);
  EXPECT_LT(worst(mesh_diagonal.v, plane_diagonal.v), 1e-12 * 0.02);
  EXPECT_LT(worst(mesh_diagonal.x, plane_diagonal.x), 1e-12 * kRadius);
  EXPECT_NEAR(mesh_diagonal.load.back().z(), -w, 1e-6 * w);
  for (const std::size_t n : mesh_diagonal.contacts) EXPECT_LE(n, 1U);
}

// --- 2. sliding and rolling across a tessellated floor -----------------------------------------

// 40 x 40 squares of 0.2 mm (a fifth of the radius) over [-4, 4] mm: a sphere crossing a few mm
// meets dozens of edges, diagonals and vertices.
constexpr int kSquares = 40;
constexpr double kFloorLo = -0.004;
constexpr double kFloorHi = 0.004;

double floor_line(int i) {
  return grid_line(kFloorLo, kFloorHi, kSquares, i);
}

/// Grid lines (x = const, y = const and the diagonals x - y = const) between the contact points
/// below @p a and @p b.
int lines_crossed(const Vector3d& a, const Vector3d& b) {
  const double h = (kFloorHi - kFloorLo) / kSquares;
  const auto count = [&](double s, double t) {
    return static_cast<int>(
        std::abs(std::floor((t - kFloorLo) / h) - std::floor((s - kFloorLo) / h)));
  };
  return count(a.x(), b.x()) + count(a.y(), b.y()) + count(a.x() - a.y(), b.x() - b.y());
}

/// A sphere starting at its resting overlap with a velocity and a spin.
struct FloorPath {
  const char* name;
  Vector3d position;
  Vector3d velocity;
  Vector3d spin;
  double friction;
  double rolling_friction;
};

/// The sphere's spin for rolling without slip at @p v on a floor: w x (-r z) = -v.
Vector3d rolling_spin(const Vector3d& v) {
  return Vector3d(-v.y(), v.x(), 0.0) / kRadius;
}

std::vector<FloorPath> floor_paths() {
  const double z = kRadius - hertz_overlap(weight());
  const Vector3d oblique = Vector3d(0.08, 0.06, 0.0);
  return {
      // Off the grid lines: across x = const lines and diagonals, face to face through edges.
      {"sliding along x", {-3.0e-3, 0.37e-3, z}, {0.15, 0.0, 0.0}, Vector3d::Zero(), 0.1, 0.0},
      // Exactly on the diagonals x = y: through their edges and the vertices on them.
      {"sliding along a diagonal",
       {floor_line(6), floor_line(6), z},
       {0.1, 0.1, 0.0},
       Vector3d::Zero(),
       0.1,
       0.0},
      // Exactly on the grid line x = x_23: over edges, crossing vertices every 0.2 mm.
      {"rolling along a grid line",
       {floor_line(23), -2.5e-3, z},
       {0.0, 0.1, 0.0},
       rolling_spin({0.0, 0.1, 0.0}),
       0.5,
       0.01},
      {"rolling obliquely", {-2.9e-3, -2.3e-3, z}, oblique, rolling_spin(oblique), 0.5, 0.01},
  };
}

Case floor_case(const FloorPath& path, bool mesh) {
  Case c = one_sphere(path.position, path.friction, path.rolling_friction);
  c.particles.edit(0).velocity = path.velocity;
  c.boundaries.push_back(mesh ? floor_mesh(tessellated_square(kFloorLo, kFloorHi, kSquares))
                              : floor_plane());
  return c;
}

Track floor_track(const FloorPath& path, bool mesh, int steps) {
  return run_track(floor_case(path, mesh), steps, [&](Scene& scene) {
    scene.particles.wx[0] = path.spin.x();
    scene.particles.wy[0] = path.spin.y();
    scene.particles.wz[0] = path.spin.z();
  });
}

constexpr int kFloorSteps = 30000;  // 30 ms

TEST(MeshFloor, SlidingAndRollingAcrossEdgesAndVerticesAsOnAPlane) {
  // Tolerance. In a face region the mesh gives the plane's gap and normal bit for bit; over an
  // edge or vertex the gap is |c - q| and the normal (c - q) / |c - q| with q on the floor, exact
  // in z and off by round-off in x, y (ulp of 4 mm coordinates, 1e-18 m): the gap is unchanged
  // (the error enters squared), the normal tilts by 1e-18 / 1e-3 = 1e-15, so the forces differ
  // by 1e-15 of the weight at such steps, the velocity by g dt 1e-15 = 1e-20 m/s each. A few
  // thousand such steps add up to 1e-16 m/s; 1e-12 of the speed (1e-13 m/s) is far above that
  // and far below any bump: an edge felt twice doubles the normal force for a step (dv = g dt =
  // 1e-5 m/s), a kink in the gap of even 1 nm changes the vertical velocity by 1e-6 m/s.
  // Measured: at most 9e-19 m/s (on the lines), 0 off them; spins and positions equal.
  for (const FloorPath& path : floor_paths()) {
    SCOPED_TRACE(path.name);
    const Track plane = floor_track(path, false, kFloorSteps);
    const Track mesh = floor_track(path, true, kFloorSteps);
    const double speed = path.velocity.norm();
    EXPECT_LT(worst(mesh.v, plane.v), 1e-12 * speed);
    EXPECT_LT(worst(mesh.w, plane.w), 1e-12 * speed / kRadius);
    EXPECT_LT(worst(mesh.x, plane.x), 1e-12 * kRadius);
    EXPECT_GE(lines_crossed(path.position, mesh.x.back()), 20);
    for (std::size_t s = 0; s < mesh.contacts.size(); ++s) {
      ASSERT_EQ(mesh.contacts[s], 1U) << "step " << s;
    }
    // Still moving at the end (the floor is crossed at speed, not crept over).
    EXPECT_GT(mesh.v.back().norm(), 0.5 * speed);
  }
}

TEST(MeshFloor, StaticFrictionHoldsASphereAcrossAVertexWithItsCarriedSpring) {
  // Gravity tilted by tan(theta) = mu / 2 towards d: static friction holds the sphere after a
  // creep s = m g sin(theta) / k_t, by which its tangential spring loads (rolling friction 1
  // blocks rolling, as in the Incline tests). Started s / 2 before the vertex at the origin (the
  // floor's middle, where six triangles and three lines meet), the contact moves from one
  // triangle into the opposite one during the creep. Were the spring reset when the contact
  // changes triangle, the sphere would creep a second s: the difference to the plane would be of
  // order s (9e-8 m). With the spring carried only rounding differs: along the diagonal the
  // contact runs through edge regions whose normal carries the closest point's rounding, and the
  // stick/slip decisions carry that on (measured: 6e-19 m along (1, 1), 0 along (2, 1)). 1e-6 s
  // is 1e5 above that and 1e6 below a reset.
  const double mu = 0.3;
  const double theta = std::atan(0.5 * mu);
  for (const Vector3d& direction :
       {Vector3d(2.0, 1.0, 0.0).normalized(), Vector3d(1.0, 1.0, 0.0).normalized()}) {
    SCOPED_TRACE(direction.transpose());
    const auto incline = [&](const Vector3d& start, bool mesh) {
      Case c = one_sphere(start, mu, 1.0);
      c.gravity = kG * (std::sin(theta) * direction - std::cos(theta) * Vector3d::UnitZ());
      c.boundaries.push_back(mesh ? floor_mesh(tessellated_square(kFloorLo, kFloorHi, kSquares))
                                  : floor_plane());
      return run_track(c, 20000);  // 20 ms: 40 contact periods, the creep has settled
    };
    const double z = kRadius - hertz_overlap(weight() * std::cos(theta));
    const Vector3d at_vertex(floor_line(20), floor_line(20), z);
    ASSERT_EQ(at_vertex.head<2>(), Eigen::Vector2d::Zero());
    const double creep = (incline(at_vertex, false).x.back() - at_vertex).dot(direction);
    EXPECT_GT(creep, 1e-10);
    EXPECT_LT(creep, 1e-3 * kRadius);  // held: nm, not the mm a slide would go
    const Vector3d start = at_vertex - 0.5 * creep * direction;
    const Track plane = incline(start, false);
    const Track mesh = incline(start, true);
    EXPECT_LT(start.head<2>().dot(direction.head<2>()), 0.0);
    EXPECT_GT(mesh.x.back().head<2>().dot(direction.head<2>()), 0.25 * creep);  // crossed
    EXPECT_LT(worst(mesh.x, plane.x), 1e-6 * creep);
    for (const std::size_t n : mesh.contacts) ASSERT_EQ(n, 1U);
  }
}

// --- 3. a mesh box corner ----------------------------------------------------------------------

constexpr double kBox = 0.006;

/// A sphere falling into the corner at the origin of the box [0, 6 mm]^3 under gravity pointing
/// into the corner, so that it ends up touching the three faces there.
Case corner_case(double friction, bool mesh, bool flip = false) {
  Case c = one_sphere(Vector3d(1.3, 1.2, 1.1) * kRadius, friction, 0.0);
  c.gravity = -kG * Vector3d(1.0, 2.0, 3.0).normalized();
  if (mesh) {
    TriangleMesh box = cube_mesh(Vector3d::Zero(), Vector3d::Constant(kBox));
    c.boundaries.push_back(
        mesh_boundary(flip ? flipped(std::move(box)) : std::move(box), Vector3d::Zero(), 0, "box"));
  } else {
    const bool open[6] = {false, false, false, false, false, false};
    c.boundaries = box_container(Vector3d::Zero(), Vector3d::Constant(kBox), 0, open, "box");
  }
  return c;
}

// With friction it rolls and bounces into the corner and rests against all three faces from
// about 29 ms on.
constexpr int kCornerSteps = 35000;

TEST(MeshBox, SphereInACornerMovesAsInTheBoxContainer) {
  // Frictionless, every face contact's force lies along one axis: the three faces' gaps are the
  // planes' distances (normals exactly +-e_k), and a sum of vectors with one non-zero component
  // each is exact in any order, so the mesh (contacts in gap order) and the six planes (in face
  // order) give the same bits.
  {
    // Without friction it slides and bounces longer: at rest on all three faces from 36 ms on.
    const Track planes = run_track(corner_case(0.0, false), 60000);
    const Track mesh = run_track(corner_case(0.0, true), 60000);
    EXPECT_TRUE(mesh == planes) << "worst x difference " << worst(mesh.x, planes.x);
    EXPECT_EQ(mesh.contacts.back(), 3U);
  }
  // With friction the tangential forces of different faces add in the same components, and the
  // mesh adds them in another order than the container: a rounding of 1e-16 of the weight per
  // step, 1e-21 m/s, growing at most linearly over 3.5e4 steps to 4e-17 m/s. 1e-11 of the fall
  // speed (0.1 m/s) bounds it (measured: 5e-18 m/s, spin 6e-15 rad/s, load 4e-19 N).
  const Track planes = run_track(corner_case(0.3, false), kCornerSteps);
  const Track mesh = run_track(corner_case(0.3, true), kCornerSteps);
  EXPECT_LT(worst(mesh.v, planes.v), 1e-11 * 0.1);
  EXPECT_LT(worst(mesh.w, planes.w), 1e-11 * 0.1 / kRadius);
  EXPECT_LT(worst(mesh.load, planes.load), 1e-11 * weight());
  EXPECT_EQ(mesh.contacts.back(), 3U);
  // At rest in the corner, the three faces carry the weight: load = m g (on the box, along g).
  EXPECT_LT(
      (mesh.load.back() - sphere_mass(kRadius, 2500.0) * corner_case(0.3, true).gravity).norm(),
      1e-6 * weight());
}

// --- 4. a convex mesh edge and corner ----------------------------------------------------------

/// A cube of half size 2 mm centred at kCubeCentre, as a mesh or as a BoxShape.
const Vector3d kCubeCentre(1.0e-3, -2.0e-3, 0.5e-3);
constexpr double kCubeHalf = 2.0e-3;

Boundary cube_boundary(bool mesh, bool flip = false) {
  if (mesh) {
    TriangleMesh cube = cube_mesh(kCubeCentre - Vector3d::Constant(kCubeHalf),
                                  kCubeCentre + Vector3d::Constant(kCubeHalf));
    return mesh_boundary(flip ? flipped(std::move(cube)) : std::move(cube), kCubeCentre, 0, "cube");
  }
  Boundary box;
  box.name = "cube";
  box.center = kCubeCentre;
  box.shape = BoxShape{Vector3d::Constant(kCubeHalf)};
  return box;
}

/// A sphere with its centre at @p feature + (r - overlap) u, u unit, no gravity.
Case outside_case(const Vector3d& feature, const Vector3d& u, double overlap, bool mesh,
                  bool flip = false) {
  Case c = one_sphere(feature + (kRadius - overlap) * u, 0.3, 0.0);
  c.gravity = Vector3d::Zero();
  c.boundaries.push_back(cube_boundary(mesh, flip));
  return c;
}

TEST(MeshEdge, SphereOnAConvexEdgeOrCornerIsPushedAlongItsNormal) {
  // Centres in the Voronoi wedge of the edge x = z = +h (at y = 0.3 h) and in the region of the
  // corner (+h, +h, +h): one contact, along u = (c - q) / |c - q|, of magnitude
  // k delta^(3/2) (Hertz, r* = r; the sphere is at rest, so no damping).
  const double overlap = 1.0e-5;
  const double phi = 35.0 * std::numbers::pi / 180.0;
  const Vector3d edge_u(std::cos(phi), 0.0, std::sin(phi));
  const Vector3d corner_u = Vector3d(1.0, 2.0, 3.0).normalized();
  const double k =
      hertz_stiffness(effective_modulus(kYoungs, kPoisson, kYoungs, kPoisson), kRadius);
  const double expected = k * overlap * std::sqrt(overlap);
  struct Feature {
    Vector3d point, u;
  };
  const Feature features[] = {
      {kCubeCentre + kCubeHalf * Vector3d(1.0, 0.3, 1.0), edge_u},
      {kCubeCentre + kCubeHalf * Vector3d(1.0, 1.0, 1.0), corner_u},
  };
  for (const Feature& feature : features) {
    SCOPED_TRACE(feature.u.transpose());
    Scene mesh_scene = build_scene(outside_case(feature.point, feature.u, overlap, true));
    Scene box_scene = build_scene(outside_case(feature.point, feature.u, overlap, false));
    const Stepper mesh_stepper(mesh_scene);
    const Stepper box_stepper(box_scene);
    const Particles& p = mesh_scene.particles;
    const Vector3d force(p.fx[0], p.fy[0], p.fz[0]);
    EXPECT_EQ(mesh_stepper.contacts().wall_contacts, 1U);
    // The gap |c - q| carries the round-off of q, 1e-18 m on mm coordinates: 1e-13 of the
    // 10 um overlap, 1.5e-13 of the force; the direction carries 1e-18 / 1 mm = 1e-15.
    EXPECT_NEAR(force.norm(), expected, 1e-12 * expected);
    EXPECT_LT((force.normalized() - feature.u).norm(), 1e-13);
    EXPECT_LT((mesh_stepper.boundary_loads()[0].force + force).norm(), 1e-15 * expected);
    const Vector3d box_force(box_scene.particles.fx[0], box_scene.particles.fy[0],
                             box_scene.particles.fz[0]);
    EXPECT_LT((force - box_force).norm(), 1e-12 * expected);
  }
  // The sphere thrown at the edge at 5 cm/s with a drift along it and friction bounces off as
  // off the box's edge: trajectories within the round-off above per contact step, 1e-12 of the
  // speed over the ~500 steps of the impact (measured: 8e-18 m/s, spin 1e-14 rad/s).
  Case mesh_case = outside_case(features[0].point, edge_u, -2e-6, true);
  Case box_case = outside_case(features[0].point, edge_u, -2e-6, false);
  for (Case* c : {&mesh_case, &box_case}) {
    c->particles.edit(0).velocity = -0.05 * edge_u + Vector3d(0.0, 0.02, 0.0);
  }
  const Track mesh = run_track(mesh_case, 3000);
  const Track box = run_track(box_case, 3000);
  EXPECT_LT(worst(mesh.v, box.v), 1e-12 * 0.05);
  EXPECT_LT(worst(mesh.w, box.w), 1e-12 * 0.05 / kRadius);
  EXPECT_GT(mesh.v.back().dot(edge_u), 0.01);  // it bounced off
  std::size_t touching = 0;
  for (const std::size_t n : mesh.contacts) {
    ASSERT_LE(n, 1U);
    touching += n;
  }
  EXPECT_GT(touching, 100U);
}

// --- 5. flipped windings -----------------------------------------------------------------------

/// The edge bounce of MeshEdge on the cube mesh, wound outward or (@p flip) inward.
Track edge_bounce(bool flip) {
  const double phi = 35.0 * std::numbers::pi / 180.0;
  const Vector3d u(std::cos(phi), 0.0, std::sin(phi));
  Case c = outside_case(kCubeCentre + kCubeHalf * Vector3d(1.0, 0.3, 1.0), u, -2e-6, true, flip);
  c.particles.edit(0).velocity = -0.05 * u + Vector3d(0.0, 0.02, 0.0);
  return run_track(c, 3000);
}

TEST(MeshWinding, FlippedNormalsChangeNothing) {
  // The mesh is two-sided (triangle_mesh.hpp): the face normal is signed towards the centre, and
  // a reversed winding negates it and the plane distance exactly; vertices and the edges computed
  // from the same first vertex (a-b and a-c swap roles, with the same dot products) do not use
  // the winding at all. So a floor crossed along its diagonal edges and through vertices, and a
  // box corner with friction, give the same bits.
  {
    const FloorPath path = floor_paths()[1];  // along the diagonal edges and through vertices
    Case flipped_case = floor_case(path, true);
    flipped_case.boundaries[0] =
        floor_mesh(flipped(tessellated_square(kFloorLo, kFloorHi, kSquares)));
    const auto spin = [&](Scene& scene) {
      scene.particles.wx[0] = path.spin.x();
      scene.particles.wy[0] = path.spin.y();
    };
    const Track a = run_track(floor_case(path, true), 10000, spin);
    const Track b = run_track(flipped_case, 10000, spin);
    EXPECT_TRUE(a == b) << "floor: worst v difference " << worst(a.v, b.v);
  }
  {
    const Track a = run_track(corner_case(0.3, true), kCornerSteps);
    const Track b = run_track(corner_case(0.3, true, true), kCornerSteps);
    EXPECT_TRUE(a == b) << "corner: worst v difference " << worst(a.v, b.v);
    EXPECT_EQ(a.contacts.back(), 3U);
  }
  // The cube's edge x = z = +h is edge 1 (b-c) of both triangles touching it, the edge whose
  // ends a reversed winding swaps: closest_on_triangle measures it from its lexicographically
  // smaller end for that reason, so this bounce is bit for bit too.
  const Track a = edge_bounce(false);
  const Track b = edge_bounce(true);
  EXPECT_TRUE(a == b) << "edge: worst v difference " << worst(a.v, b.v);
}

// --- 6. loads of moving meshes -----------------------------------------------------------------

TEST(MovingMesh, TranslatingBladeLoadBalancesTheParticlesMomentum) {
  // A blade of 12 triangles (1 x 20 x 6 mm) moving at 0.1 m/s pushes a row of four spheres on a
  // frictionless floor. Velocity Verlet changes momentum by dt/2 (F_k + F_k+1) per step, the
  // trapezoid rule over successive evaluations, so the blade's integrated load equals minus the
  // momentum change to round-off of the sums (1e-9 relative leaves a wide margin over 1e4 steps
  // of 1e-16).
  Case c = testing::row_on_floor(4, 0.3, 1e-6);
  const Vector3d centre(0.0024, 0.005, 0.003);  // front face 0.1 mm behind the row
  const Vector3d half(0.0005, 0.01, 0.003);
  Boundary blade = mesh_boundary(cube_mesh(centre - half, centre + half), centre, 0, "blade");
  blade.motion.keys = {{0.0, Vector3d(0.1, 0.0, 0.0)}};
  c.boundaries.push_back(blade);
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  const Particles& p = scene.particles;
  const auto momentum_x = [&] {
    double sum = 0.0;
    for (std::size_t i = 0; i < p.size(); ++i) sum += p.mass[i] * p.vx[i];
    return sum;
  };
  const double start = momentum_x();
  double impulse = 0.0;
  double previous = -stepper.boundary_loads()[1].force.x();
  for (int s = 0; s < 10000; ++s) {  // 10 ms: the blade travels 0.9 mm into the row
    stepper.step();
    const double current = -stepper.boundary_loads()[1].force.x();
    impulse += 0.5 * c.time_step * (previous + current);
    previous = current;
  }
  EXPECT_GT(impulse, 0.0);
  EXPECT_NEAR(momentum_x() - start, impulse, 1e-9 * std::abs(impulse));
  EXPECT_NEAR(scene.boundaries[1].center.x(), centre.x() + 0.1 * 0.01, 1e-12);
  double front = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) front = std::max(front, p.x[i]);
  EXPECT_GT(front, 0.004 + 0.0021 * 3 + 1e-4) << "the push must reach the last particle";
}

TEST(MovingMesh, RotatingPaddleMomentIsRCrossFAndBalancesAngularMomentum) {
  // A vertical paddle (two triangles, 20 x 3 mm, in the plane y = 0 at rest), its turn rate
  // about the z axis through its centre ramping from 0 to 20 rad/s over 20 ms, presses three
  // spheres that touch it at the start across a frictionless floor. Every force on the spheres
  // besides the paddle's is vertical (gravity, the floor), so about the z axis
  //   - the paddle's moment (on the paddle) is -sum_i ((c_i - C) x F_i)_z with F_i the horizontal
  //     force on sphere i, exactly when each contact force lies along its normal (frictionless:
  //     the contact point and the centre then give the same lever);
  //   - velocity Verlet conserves angular momentum exactly (r_k+1 - r_k is along v_k+1/2): the
  //     spheres' L_z changes by the trapezoid sum of those torques.
  // Contact damping 0.9: the spheres hardly rebound and stay pressed against the paddle.
  Case c = testing::row_on_floor(0, 0.9, 1e-6);
  c.domain->min = Vector3d(-0.015, -0.015, -0.002);
  c.domain->max = Vector3d(0.015, 0.015, 0.01);
  c.domain->periodic = {false, false, false};
  for (const Vector3d& at : {Vector3d(3e-3, kRadius, kRadius), Vector3d(6e-3, kRadius, kRadius),
                             Vector3d(-4.5e-3, -kRadius, kRadius)}) {
    ParticleSpec p;
    p.radius = kRadius;
    p.position = at;
    c.particles.push_back(p);
  }
  const Vector3d centre = Vector3d::Zero();
  TriangleMesh paddle = make_mesh(
      {{-0.01, 0.0, 0.1e-3}, {0.01, 0.0, 0.1e-3}, {0.01, 0.0, 3.1e-3}, {-0.01, 0.0, 3.1e-3}},
      {{0, 1, 2}, {0, 2, 3}});
  Boundary blade = mesh_boundary(std::move(paddle), centre, 0, "paddle");
  blade.motion.axis = Vector3d::UnitZ();
  blade.motion.keys = {{0.0, Vector3d::Zero(), 0.0}, {0.02, Vector3d::Zero(), 20.0}};
  blade.motion.interpolation = MotionInterpolation::kLinear;
  c.boundaries.push_back(blade);
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  const Particles& p = scene.particles;
  const auto angular_momentum = [&] {
    double sum = 0.0;
    for (std::size_t i = 0; i < p.size(); ++i) {
      sum += p.mass[i] * ((p.x[i] - centre.x()) * p.vy[i] - (p.y[i] - centre.y()) * p.vx[i]);
    }
    return sum;
  };
  const auto torque_on_spheres = [&] {
    double sum = 0.0;
    for (std::size_t i = 0; i < p.size(); ++i) {
      sum += (p.x[i] - centre.x()) * p.fy[i] - (p.y[i] - centre.y()) * p.fx[i];
    }
    return sum;
  };
  const double start = angular_momentum();
  double angular_impulse = 0.0;
  double previous = -stepper.boundary_loads()[1].moment.z();
  double largest = 0.0;
  double worst_lever = 0.0;
  int pushing = 0;
  for (int s = 0; s < 20000; ++s) {  // 20 ms: 0.2 rad
    stepper.step();
    ASSERT_EQ(stepper.contacts().contacts, 0U);  // the spheres never touch each other
    const double moment = stepper.boundary_loads()[1].moment.z();
    worst_lever = std::max(worst_lever, std::abs(moment + torque_on_spheres()));
    largest = std::max(largest, std::abs(moment));
    pushing += moment != 0.0 ? 1 : 0;
    angular_impulse += 0.5 * c.time_step * (previous - moment);
    previous = -moment;
  }
  EXPECT_GT(pushing, 15000);
  // A handful of products and sums of mm levers and mN forces: 1e-15 relative per step
  // (measured: 2e-22 N m of 9e-7 N m).
  EXPECT_LT(worst_lever, 1e-13 * largest);
  EXPECT_GT(angular_impulse, 0.0);
  EXPECT_NEAR(angular_momentum() - start, angular_impulse, 1e-9 * std::abs(angular_impulse));
  // A ramp is read at mid-step, its exact mean: the angle is the ramp's integral, 0.2 rad.
  EXPECT_NEAR(scene.boundaries[1].angle, 0.5 * 20.0 * 0.02, 1e-12);
  // The paddle turned the spheres with it: each moves at least at about the speed of the paddle
  // at its starting radius (the nearest, 3 mm, gives 0.06 m/s; it also slides outwards).
  for (std::size_t i = 0; i < p.size(); ++i) EXPECT_GT(std::hypot(p.vx[i], p.vy[i]), 0.05);
}

// --- 7. threads and restart with moving meshes -------------------------------------------------

/// About 1370 frictional spheres (r 0.4-0.6 mm, 0.5 m/s) in a 16 mm box of five planes over a
/// tessellated mesh floor (16 x 16 squares), stirred by a paddle mesh (a 12-triangle slab) that
/// turns about z at 100 rad/s while translating on a velocity ramp: mesh contact slots and
/// springs on a moving and a static mesh, and the parallel loops (above kMinParallelParticles).
Case stirred_gas(double end) {
  Case c = testing::soft_case(0.0);
  c.contact.restitution = 0.5;
  c.contact.friction = 0.5;
  c.contact.rolling_friction = 0.05;
  c.gravity = Vector3d(0.0, 0.0, -kG);
  c.time_step = 1.0e-6;
  c.end_time = end;
  c.history_interval = 1.0e-4;
  c.checkpoint_interval = 0.0;
  const double length = 0.016;
  testing::add_random_gas(c, 1400, 0.4e-3, 0.6e-3, length, 0.5, 23);
  // Spheres overlapping the paddle (or within 20 um of it) at the start are taken out; its faces
  // then sweep into the others at once.
  const Vector3d axis_point(0.008, 0.008, 0.008);
  const Vector3d half(4e-3, 0.5e-3, 1.5e-3);
  const BoxShape slab{half};
  std::erase_if(c.particles.expanded(), [&](const ParticleSpec& p) {
    return slab.nearest(p.position - axis_point).gap < p.radius + 2e-5;
  });
  const bool open[6] = {false, false, false, false, true, false};  // the floor is a mesh
  c.boundaries = box_container(Vector3d::Zero(), Vector3d::Constant(length), 0, open, "box");
  c.boundaries.push_back(
      mesh_boundary(tessellated_square(0.0, length, 16), Vector3d::Zero(), 0, "floor"));
  Boundary paddle =
      mesh_boundary(cube_mesh(axis_point - half, axis_point + half), axis_point, 0, "paddle");
  paddle.motion.axis = Vector3d::UnitZ();
  paddle.motion.keys = {{0.0, Vector3d(0.3, 0.0, 0.0), 100.0},
                        {0.5e-3, Vector3d(-0.3, 0.1, 0.0), 100.0}};
  paddle.motion.interpolation = MotionInterpolation::kLinear;
  c.boundaries.push_back(paddle);
  return c;
}

/// Whether column @p name of CSV text @p csv (a header line, then rows) is non-zero in some row.
bool column_ever_nonzero(const std::string& csv, const std::string& name) {
  std::istringstream lines(csv);
  std::string line;
  std::getline(lines, line);
  std::istringstream header(line);
  std::string cell;
  int column = 0;
  while (std::getline(header, cell, ',') && cell != name) ++column;
  if (cell != name) return false;
  while (std::getline(lines, line)) {
    std::istringstream row(line);
    for (int k = 0; k <= column; ++k) std::getline(row, cell, ',');
    if (std::stod(cell) != 0.0) return true;
  }
  return false;
}

TEST(MovingMesh, RestartAndThreadBitForBit) {
  namespace fs = std::filesystem;
  const double end = 1.2e-3;
  ASSERT_GE(stirred_gas(end).particles.size(), 1100U);
  const fs::path whole = testing::fresh_directory("mesh_boundary_whole");
  const fs::path half = testing::fresh_directory("mesh_boundary_half");
  const fs::path serial = testing::fresh_directory("mesh_boundary_serial");
  const int threads = omp_get_max_threads();
  omp_set_num_threads(2);
  const RunResult result = testing::quiet_run(stirred_gas(end), whole);
  EXPECT_EQ(result.threads, 2);
  // At the end (measured 83 and 19): pair and boundary springs are in use.
  EXPECT_GT(result.contacts.contacts, 40U);
  EXPECT_GT(result.contacts.wall_contacts, 8U);
  // Restarted at 0.6 ms, after the paddle's ramp turned its velocity round.
  testing::quiet_run(stirred_gas(0.6e-3), half);
  testing::quiet_run(stirred_gas(end), half, (half / "checkpoint.bin").string());
  omp_set_num_threads(1);
  testing::quiet_run(stirred_gas(end), serial);
  omp_set_num_threads(threads);
  for (const char* file : {"final_state.csv", "history.csv", "checkpoint.bin"}) {
    SCOPED_TRACE(file);
    const std::string reference = testing::file_bytes(whole / file);
    EXPECT_FALSE(reference.empty());
    EXPECT_TRUE(reference == testing::file_bytes(half / file));
    EXPECT_TRUE(reference == testing::file_bytes(serial / file));
  }
  // The moving paddle and the mesh floor both pushed spheres: their loads in history.csv.
  const std::string history = testing::file_bytes(whole / "history.csv");
  EXPECT_TRUE(column_ever_nonzero(history, "load_paddle_x"));
  EXPECT_TRUE(column_ever_nonzero(history, "moment_paddle_z"));
  EXPECT_TRUE(column_ever_nonzero(history, "load_floor_z"));
}

}  // namespace
}  // namespace bondem
