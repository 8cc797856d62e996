// The sphere tool, the shape added by following CONTRIBUTING.md's "Add a boundary shape": its
// geometry, its motion, a particle resting on it, the reader and the VTK outline.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>
#include <variant>

#include "case_text.hpp"
#include "io/case_file.hpp"
#include "io/vtk_output.hpp"
#include "scene_builders.hpp"
#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"

namespace bondem {
namespace {

Boundary sphere_tool(const Eigen::Vector3d& center, double radius) {
  Boundary body;
  body.name = "ball";
  body.center = center;
  body.shape = SphereShape{radius};
  return body;
}

TEST(SphereTool, GapAndNormalOutsideTouchingAndInside) {
  const Eigen::Vector3d centre(0.1, -0.2, 0.3);
  const Boundary ball = sphere_tool(centre, 0.004);
  const Eigen::Vector3d direction = Eigen::Vector3d(2.0, -1.0, 2.0) / 3.0;  // unit
  // Positions near 0.3 m carry rounding of 3e-17 m; over a distance of 1 mm that tilts the
  // normal by up to about 1e-13.
  constexpr double kTilt = 1e-13;

  const SurfacePoint outside = nearest_surface(ball, centre + 0.005 * direction);
  EXPECT_NEAR(outside.gap, 0.001, 1e-15);
  EXPECT_NEAR((outside.normal - direction).norm(), 0.0, kTilt);

  const SurfacePoint touching = nearest_surface(ball, centre + 0.004 * direction);
  EXPECT_NEAR(touching.gap, 0.0, 1e-15);
  EXPECT_NEAR((touching.normal - direction).norm(), 0.0, kTilt);

  // Centre inside: negative gap, the normal still points out through the nearest surface.
  const SurfacePoint inside = nearest_surface(ball, centre - 0.001 * direction);
  EXPECT_NEAR(inside.gap, -0.003, 1e-15);
  EXPECT_NEAR((inside.normal + direction).norm(), 0.0, kTilt);

  // Exactly at the centre every direction is nearest: a unit normal (documented +z), gap -R.
  const SurfacePoint middle = nearest_surface(ball, centre);
  EXPECT_EQ(middle.gap, -0.004);
  EXPECT_EQ(middle.normal, Eigen::Vector3d::UnitZ());
}

TEST(SphereTool, QuickApartTestAgreesWithTheExactGap) {
  // The kernel skips the tool when surely_apart holds; it must hold exactly when the exact gap
  // reaches the particle radius (except within rounding of the gap, 1e-12 m, of touching).
  const Boundary ball = sphere_tool(Eigen::Vector3d(0.1, -0.2, 0.3), 0.003);
  const double r = 1e-3;
  int apart = 0, touching = 0;
  for (int a = -12; a <= 12; ++a) {
    for (int b = -12; b <= 12; ++b) {
      for (int c = -12; c <= 12; ++c) {
        const Eigen::Vector3d point = ball.center + 0.00041 * Eigen::Vector3d(a, b, c);
        const double gap = nearest_surface(ball, point).gap;
        if (std::abs(gap - r) < 1e-12) continue;
        EXPECT_EQ(surely_apart(ball, point, r), gap >= r) << a << ' ' << b << ' ' << c;
        (gap >= r ? apart : touching) += 1;
      }
    }
  }
  EXPECT_GT(apart, 1000);
  EXPECT_GT(touching, 1000);
  // Right at the touching distance, on an axis where the sums are exact: apart, and just inside
  // it, not.
  EXPECT_TRUE(surely_apart(ball, ball.center + Eigen::Vector3d(0.0, 0.0, 0.004), r));
  EXPECT_FALSE(surely_apart(ball, ball.center + Eigen::Vector3d(0.0, 0.0, 0.0039999), r));
}

TEST(SphereTool, MovesWithItsMotionAndItsSurfaceWithIt) {
  Case c = testing::soft_case(0.3);
  Boundary ball = sphere_tool(Eigen::Vector3d(0.0, 0.0, 0.0), 0.002);
  const Eigen::Vector3d v(0.3, -0.1, 0.05);
  ball.motion.keys = {{0.0, Eigen::Vector3d::Zero()}, {1e-4, v}};
  c.boundaries.push_back(ball);
  ParticleSpec far;  // the stepper needs a particle; this one never comes near
  far.radius = 1e-3;
  far.position = Eigen::Vector3d(0.05, 0.05, 0.05);
  c.particles.push_back(far);
  Domain d;
  d.min = Eigen::Vector3d::Constant(-0.1);
  d.max = Eigen::Vector3d::Constant(0.1);
  c.domain = d;
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  for (int s = 0; s < 300; ++s) stepper.step();  // 0.3 ms: 0.2 ms of it moving
  const Boundary& moved = scene.boundaries[0];
  EXPECT_EQ(moved.velocity, v);
  // 0.2 ms at v, give or take the one step in which the key takes over.
  EXPECT_NEAR((moved.center - 2e-4 * v).norm(), 0.0, 1.01 * c.time_step * v.norm());
  // No spin: every surface point moves with the sphere's translation.
  for (const Eigen::Vector3d& offset :
       {Eigen::Vector3d(0.002, 0.0, 0.0), Eigen::Vector3d(0.0, -0.002, 0.0),
        Eigen::Vector3d(0.0, 0.0, 0.002)}) {
    EXPECT_EQ(surface_velocity(moved, moved.center + offset), v);
  }
  EXPECT_EQ(rotation_speed(moved), 0.0);
}

/// One particle of radius 1 mm a little above a fixed sphere tool of radius @p tool_radius, under
/// gravity, with contact damping @p damping.
Case drop_on_sphere(double tool_radius, double damping, double height) {
  Case c = testing::soft_case(damping);
  c.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  c.time_step = 2e-6;
  ParticleSpec p;
  p.radius = 1e-3;
  p.position = Eigen::Vector3d(0.0, 0.0, tool_radius + 1e-3 + height);
  c.particles.push_back(p);
  c.boundaries.push_back(sphere_tool(Eigen::Vector3d::Zero(), tool_radius));
  Domain d;
  d.min = Eigen::Vector3d::Constant(-0.02);
  d.max = Eigen::Vector3d::Constant(0.02);
  c.domain = d;
  return c;
}

TEST(SphereTool, ParticleDroppedOnItRestsOnTopAtTheHertzOverlapOfItsWeight) {
  const double tool_radius = 0.005;
  Case c = drop_on_sphere(tool_radius, 0.5, 2e-4);
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  const Particles& p = scene.particles;
  double lowest = p.z[0];
  for (int s = 0; s < 100000; ++s) {  // 0.2 s
    stepper.step();
    lowest = std::min(lowest, p.z[0]);
  }
  // Hertz with r* = r (a tool, like a wall, is taken as locally flat, see docs/case-file.md):
  // 4/3 E* sqrt(r) delta^1.5 = m g.
  const double e_star = c.pair_coefficients(0, 0).effective_modulus;
  const double weight = p.mass[0] * 9.81;
  const double delta = std::pow(weight / (4.0 / 3.0 * e_star * std::sqrt(1e-3)), 2.0 / 3.0);
  ASSERT_GT(delta, 1e-7);
  const double rest = tool_radius + 1e-3 - delta;
  EXPECT_LT(lowest, rest);  // it did fall onto the sphere and past the resting height
  EXPECT_NEAR(p.z[0], rest, 1e-3 * delta);
  EXPECT_NEAR(p.x[0], 0.0, 1e-12);  // on top: no sideways force on the axis
  EXPECT_NEAR(p.y[0], 0.0, 1e-12);
  EXPECT_NEAR(p.vz[0], 0.0, 1e-6);
  // The tool carries the weight: the load on it (the only boundary) is the particle's weight.
  EXPECT_NEAR(stepper.boundary_loads()[0].force.z(), -weight, 1e-3 * weight);
}

TEST(SphereTool, ParticleFallingOffCentreSlidesOffItAndFallsPast) {
  // A little off the top, frictionless: pushed outward along the radius, it slides off and falls
  // past the sphere's equator instead of resting on it.
  const double tool_radius = 0.005;
  Case c = drop_on_sphere(tool_radius, 0.3, 1e-4);
  c.particles.edit(0).position.x() = 5e-4;
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  const Particles& p = scene.particles;
  for (int s = 0; s < 150000; ++s) stepper.step();  // 0.3 s
  EXPECT_GT(p.x[0], tool_radius + 1e-3);            // pushed away along +x, never across to -x
  EXPECT_GT(p.vx[0], 0.0);
  EXPECT_LT(p.z[0], 0.0);
}

const std::string kSphereCase = R"(materials:
  powder: {density: 2000, youngs_modulus: 1.0e9, poisson_ratio: 0.3}
  steel: {density: 7800, youngs_modulus: 2.0e11, poisson_ratio: 0.3}
contact:
  damping_ratio: 0.1
bond:
  alpha: 1
  equilibrium_overlap: 5.0e-5
  damping_ratio: 0.5
  criterion: never
time: {step: 1.0e-7, end: 0.001}
particles:
  - {material: powder, radius: 0.001, position: [0, 0, 0.01]}
walls:
  - {type: sphere, center: [0.0, 0.0, 0.002], radius: 0.003, material: steel, name: indenter,
     motion: [{time: 0.0, velocity: [0.0, 0.0, 0.1]}]}
output:
  directory: out
)";

TEST(SphereTool, ReaderAcceptsItAndRefusesABadRadiusNamingTheKey) {
  const Case c = parse_case(kSphereCase, "case.yaml", {});
  ASSERT_EQ(c.boundaries.size(), 1u);
  const Boundary& ball = c.boundaries[0];
  ASSERT_TRUE(std::holds_alternative<SphereShape>(ball.shape));
  EXPECT_EQ(std::get<SphereShape>(ball.shape).radius, 0.003);
  EXPECT_EQ(ball.center, Eigen::Vector3d(0.0, 0.0, 0.002));
  EXPECT_EQ(ball.name, "indenter");
  EXPECT_EQ(ball.material, 1);
  ASSERT_EQ(ball.motion.keys.size(), 1u);
  EXPECT_EQ(ball.motion.keys[0].velocity, Eigen::Vector3d(0.0, 0.0, 0.1));

  for (const char* bad : {"0", "-0.003", "nan", "[1, 2]"}) {
    const std::string error = testing::error_of(
        testing::replace(kSphereCase, "radius: 0.003", std::string("radius: ") + bad));
    EXPECT_NE(error.find("'walls.0.radius'"), std::string::npos) << bad << ": " << error;
  }
  EXPECT_NE(testing::error_of(testing::replace(kSphereCase, "radius: 0.003, ", ""))
                .find("'walls.0.radius': missing required key"),
            std::string::npos);
  EXPECT_NE(testing::error_of(testing::replace(kSphereCase, "center:", "point:"))
                .find("'walls.0.point': unknown key (expected one of: type, center, radius, "
                      "material, motion, name, temperature)"),
            std::string::npos);
  // An unknown type lists the sphere among the known ones.
  EXPECT_NE(testing::error_of(testing::replace(kSphereCase, "type: sphere", "type: ball"))
                .find("unknown wall type 'ball' (box, plane, blade, roller, sphere or mesh)"),
            std::string::npos);
}

TEST(SphereTool, VtkOutlineIsAClosedSphereAtTheToolsPosition) {
  namespace fs = std::filesystem;
  const fs::path dir =
      fs::temp_directory_path() / ("bondem_sphere_vtk_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const Eigen::Vector3d centre(0.001, 0.002, 0.003);
  const double radius = 0.0015;
  Boundary ball = sphere_tool(centre, radius);
  ball.material = 2;
  Domain domain;
  domain.max = Eigen::Vector3d::Constant(0.01);
  {
    VtkSeriesWriter writer(dir.string());
    Particles none;
    writer.write_frame(0.0, none, {}, {ball}, domain);
  }
  const VtpContents tools = read_vtp((dir / "tools_000000.vtp").string());
  fs::remove_all(dir);
  EXPECT_EQ(tools.polys, 16u * 8u);  // 16 meridians by 8 bands
  double area = 0.0;
  for (const std::vector<std::int64_t>& cell : tools.cells) {
    ASSERT_GE(cell.size(), 3u);
    // Every polygon is planar-ish and faces outward: its (Newell) normal points away from the
    // centre; summed, the areas approach the sphere's from below.
    Eigen::Vector3d normal = Eigen::Vector3d::Zero();
    Eigen::Vector3d middle = Eigen::Vector3d::Zero();
    for (std::size_t k = 0; k < cell.size(); ++k) {
      const Eigen::Vector3d& a = tools.points[static_cast<std::size_t>(cell[k])];
      const Eigen::Vector3d& b =
          tools.points[static_cast<std::size_t>(cell[(k + 1) % cell.size()])];
      normal += a.cross(b);
      middle += a / static_cast<double>(cell.size());
    }
    EXPECT_GT(normal.dot(middle - centre), 0.0);
    area += 0.5 * normal.norm();
  }
  for (const Eigen::Vector3d& point : tools.points) {
    EXPECT_NEAR((point - centre).norm(), radius, 1e-15);
  }
  const double sphere_area = 4.0 * std::numbers::pi * radius * radius;
  EXPECT_LT(area, sphere_area);
  EXPECT_GT(area, 0.95 * sphere_area);
  const VtpArray* material = tools.cell_array("material");
  ASSERT_NE(material, nullptr);
  for (const double m : material->values) EXPECT_EQ(m, 2.0);
}

}  // namespace
}  // namespace bondem
