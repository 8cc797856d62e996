// Contact models per material pair in stepped scenes: JKR contacts settle at the closed-form
// zero-load overlap (pairs and walls), a wall's pair takes its own restitution and friction,
// EPSD rolling rocks a sphere at its closed-form period, and runs with JKR and EPSD history
// restart and thread bit for bit.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>

#include "case_text.hpp"
#include "io/case_file.hpp"
#include "io/checkpoint.hpp"
#include "io/run.hpp"
#include "run_helpers.hpp"
#include "scene_builders.hpp"
#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"
#include "solver/models/pair.hpp"

namespace bondem {
namespace {

using testing::replace;

/// Two 100 um powder spheres touching by 1 nm, and a steel floor far below; no gravity.
const std::string kPair = R"(materials:
  powder: {density: 2500, youngs_modulus: 1.0e7, poisson_ratio: 0.3}
  steel: {density: 7800, youngs_modulus: 1.0e7, poisson_ratio: 0.3}
contact:
  restitution: 0.3
  cohesion: {model: jkr, surface_energy: 0.1}
time: {step: 5.0e-7, end: 2.0e-3}
walls:
  - {type: plane, point: [0, 0, -1.0e-3], normal: [0, 0, 1], material: steel, name: floor}
particles:
  - {material: powder, radius: 1.0e-4, position: [0, 0, 0]}
  - {material: powder, radius: 1.0e-4, position: [1.99999e-4, 0, 0]}
output: {directory: out}
)";

/// JKR overlap at zero load: a0^3 = 9 pi w r*^2 / (2 E*), delta0 = a0^2 / (3 r*) (Johnson,
/// Contact Mechanics, 1985, sec. 5.5).
double jkr_rest_overlap(double r_star, double e_star, double w) {
  const double a0 = std::cbrt(9.0 * std::numbers::pi * w * r_star * r_star / (2.0 * e_star));
  return a0 * a0 / (3.0 * r_star);
}

/// Steps @p stepper for the case's whole time.
void run_to_end(const Case& c, Stepper& stepper) {
  const auto steps = static_cast<long>(std::llround(c.end_time / c.time_step));
  for (long s = 0; s < steps; ++s) stepper.step();
}

TEST(JkrContact, PairSettlesAtTheZeroLoadOverlap) {
  const Case c = parse_case(kPair, "case.yaml");
  Scene scene = build_scene(c);
  EXPECT_GT(scene.contact_range, 0.0);  // the list reaches past touching
  Stepper stepper(scene);
  run_to_end(c, stepper);
  const Particles& p = scene.particles;
  const double overlap = 2.0e-4 - std::abs(p.x[1] - p.x[0]);
  const double e_star = effective_modulus(1e7, 0.3, 1e7, 0.3);
  const double expected = jkr_rest_overlap(effective_radius(1e-4, 1e-4), e_star, 0.1);
  // 40 damped periods: the residual oscillation is far below the 1e-4 asked; the closed form is
  // exact for the law at rest (no damping force).
  EXPECT_NEAR(overlap, expected, 1e-4 * expected);
  EXPECT_LT(std::abs(p.vx[0]), 1e-6);
}

TEST(JkrContact, WallPairSettlesWithTheParticleAsEffectiveRadius) {
  // Only powder-steel is cohesive: the particle on the floor sticks, r* = r.
  const std::string text = replace(
      replace(replace(kPair, "  cohesion: {model: jkr, surface_energy: 0.1}\n", ""), "time: {",
              "interactions:\n  - materials: [powder, steel]\n    cohesion: {model: jkr, "
              "surface_energy: 0.1}\ntime: {"),
      "  - {material: powder, radius: 1.0e-4, position: [1.99999e-4, 0, 0]}\n", "");
  // Touching the floor and moving onto it at 0.1 mm/s: the contact forms at the first overlap.
  const Case c = parse_case(
      replace(text, "position: [0, 0, 0]", "position: [0, 0, -0.9e-3], velocity: [0, 0, -1.0e-4]"),
      "case.yaml");
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  run_to_end(c, stepper);
  const double overlap = 1.0e-4 - (scene.particles.z[0] + 1.0e-3);
  const double expected = jkr_rest_overlap(1.0e-4, effective_modulus(1e7, 0.3, 1e7, 0.3), 0.1);
  EXPECT_NEAR(overlap, expected, 1e-4 * expected);
}

TEST(JkrContact, PullOffBreaksTheContactOnlyPastTheSeparationOverlap) {
  // The pair pulled apart at 1 mm/s: the force is attractive while the overlap is negative, and
  // vanishes once the gap exceeds the separation distance.
  Case c = parse_case(kPair, "case.yaml", {"contact.restitution=1", "time.end=1.0e-5"});
  c.particles.edit(1).position.x() =
      2.0e-4 - jkr_rest_overlap(5e-5, effective_modulus(1e7, 0.3, 1e7, 0.3), 0.1);
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  // Hold the particles by resetting their velocities each step: a quasi-static separation.
  Particles& p = scene.particles;
  // Fast enough that the attraction's kick (dt/2 x pull-off / m, 0.6 mm/s) cannot hold them.
  const double speed = 1e-2;
  bool attracted_apart = false;
  double released_at = 0.0;
  for (int s = 0; s < 1000 && released_at == 0.0; ++s) {
    p.vx[0] = -0.5 * speed;
    p.vx[1] = 0.5 * speed;
    stepper.step();
    const double overlap = 2.0e-4 - (p.x[1] - p.x[0]);
    if (overlap < 0.0 && p.fx[0] > 0.0) attracted_apart = true;
    if (stepper.contacts().contacts == 0) released_at = overlap;
  }
  EXPECT_TRUE(attracted_apart);
  const double separation = separation_overlap(scene.pair(0, 0), effective_radius(1e-4, 1e-4));
  // The contact ends at the first step past the separation overlap: within one step's travel.
  EXPECT_LE(released_at, separation);
  EXPECT_GT(released_at, separation - speed * c.time_step * 1.01);
}

/// A particle moving onto the steel floor at 0.5 m/s, no gravity, with @p interactions after the
/// defaults: rebound speed / impact speed.
double wall_rebound(const std::string& interactions) {
  std::string text = replace(kPair, "  cohesion: {model: jkr, surface_energy: 0.1}\n", "");
  text =
      replace(text, "  - {material: powder, radius: 1.0e-4, position: [1.99999e-4, 0, 0]}\n", "");
  text = replace(text, "position: [0, 0, 0]}",
                 "position: [0, 0, -0.8999e-3], velocity: [0, 0, -0.5]}");
  text = replace(text, "time: {", interactions + "time: {");
  // About 230 steps per impact: the step's error in e is below 0.1 %.
  const Case c = parse_case(text, "case.yaml", {"time.step=1.0e-7"});
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  run_to_end(c, stepper);
  return scene.particles.vz[0] / 0.5;
}

TEST(WallPair, TakesTheRestitutionOfItsInteraction) {
  // The wall is a partner of infinite radius and mass: e maps to xi by the same relation.
  EXPECT_NEAR(wall_rebound(""), 0.3, 0.002 * 0.3);
  EXPECT_NEAR(wall_rebound("interactions:\n  - {materials: [powder, steel], restitution: 0.8}\n"),
              0.8, 0.002 * 0.8);
}

/// One powder sphere (r = 100 um) resting on the steel floor under gravity at its Hertz overlap,
/// moving at @p velocity along x; contact keys @p contact.
struct Resting {
  Case c;
  double radius = 1.0e-4;
  double mass = 0.0;
  double overlap = 0.0;  ///< Hertz overlap under its weight
};
Resting resting_sphere(const std::string& contact, double velocity, double end) {
  Resting r;
  const double e_star = effective_modulus(1e7, 0.3, 1e7, 0.3);
  r.mass = sphere_mass(r.radius, 2500.0);
  r.overlap = std::pow(r.mass * 9.81 / hertz_stiffness(e_star, r.radius), 2.0 / 3.0);
  const std::string text =
      "materials:\n"
      "  powder: {density: 2500, youngs_modulus: 1.0e7, poisson_ratio: 0.3}\n"
      "  steel: {density: 7800, youngs_modulus: 1.0e7, poisson_ratio: 0.3}\n"
      "contact: " +
      contact +
      "\n"
      "gravity: [0, 0, -9.81]\n"
      "time: {step: 5.0e-7, end: " +
      std::to_string(end) +
      "}\n"
      "walls:\n"
      "  - {type: plane, point: [0, 0, 0], normal: [0, 0, 1], material: steel, name: floor}\n"
      "particles:\n"
      "  - {material: powder, radius: 1.0e-4, position: [0, 0, 1.0e-3]}\n"
      "output: {directory: out}\n";
  r.c = parse_case(text, "case.yaml");
  // Placed in code: the reader refuses a particle overlapping a wall.
  r.c.particles.edit(0).position.z() = r.radius - r.overlap;
  r.c.particles.edit(0).velocity.x() = velocity;
  return r;
}

TEST(WallPair, SlidesWithTheFrictionOfItsInteraction) {
  // A sphere launched sliding at v0: Coulomb friction mu m g decelerates it at mu g until it rolls
  // (at t = 2 v0 / (7 mu g)). The floor's pair has mu = 0.1, the default 0.5 would roll by 0.6 ms.
  const double v0 = 0.01;
  const double t1 = 1.5e-3;  // before rolling at mu = 0.1 (2.9 ms)
  Resting r = resting_sphere(
      "{restitution: 0.1, friction: 0.5}\ninteractions:\n  - {materials: [powder, steel], "
      "friction: 0.1}",
      v0, t1);
  Scene scene = build_scene(r.c);
  Stepper stepper(scene);
  run_to_end(r.c, stepper);
  const double expected = v0 - 0.1 * 9.81 * t1;
  // The normal load oscillates about m g by the contact's start-up transient (the tangential
  // spring's elastic stage shortens the slide by about a contact period): 1 % of the decrease.
  EXPECT_NEAR(scene.particles.vx[0], expected, 0.01 * (v0 - expected));
}

TEST(EpsdRolling, SphereOnAFloorRocksAtTheSpringsPeriod) {
  // Rolling without slip at omega0 = 0.5 rad/s, below the spring's plastic limit (the angle
  // reached, omega0 / Omega = 1.2e-4 rad, against mu_r r F_n / k_r = 3.8e-4 rad): the EPSD spring
  // alone (no damper) stops and returns it, a quarter period T/4 = (pi/2) sqrt(I_r / k_r) after
  // the start, I_r = 7/5 m r^2 about the contact point, k_r = 2.25 k_n mu_r^2 r^2 with the
  // Hertz tangent stiffness k_n = 2 E* sqrt(r delta) (Ai et al. 2011, model C).
  const double omega0 = 0.5;
  Resting r = resting_sphere(
      "{restitution: 0.1, friction: 0.5, rolling_friction: 0.1, rolling_model: epsd, "
      "rolling_damping: 0}",
      omega0 * 1.0e-4, 1.0e-3);
  Scene scene = build_scene(r.c);
  scene.particles.wy[0] = omega0;
  Stepper stepper(scene);
  const double e_star = effective_modulus(1e7, 0.3, 1e7, 0.3);
  const double k_n = 2.0 * e_star * std::sqrt(r.radius * r.overlap);
  const double k_r = 2.25 * k_n * 0.1 * 0.1 * r.radius * r.radius;
  const double inertia = 1.4 * r.mass * r.radius * r.radius;
  const double quarter = 0.5 * std::numbers::pi * std::sqrt(inertia / k_r);
  // The zero crossing is found to a step (0.14 % of T/4); the tangential spring, in series with
  // the rolling one, lengthens the period a little more (measured: 0.27 % in all).
  double stopped_at = 0.0;
  for (int s = 0; s < 4000 && stopped_at == 0.0; ++s) {
    stepper.step();
    if (scene.particles.wy[0] <= 0.0) stopped_at = stepper.time();
  }
  EXPECT_NEAR(stopped_at, quarter, 0.01 * quarter) << stopped_at / quarter;
}

/// 2000 soft spheres (r 0.4-0.6 mm) shaken in a box, walls all round, with JKR cohesion and
/// EPSD rolling: contact history on pairs and walls from the first steps, parallel loops in use.
Case sticky_gas(double end) {
  Case c = testing::soft_case(0.0);
  c.contact.restitution = 0.5;
  c.contact.friction = 0.5;
  c.contact.rolling_friction = 0.1;
  c.contact.rolling_model = RollingModel::kEpsd;
  c.contact.cohesion = CohesionModel::kJkr;
  c.contact.cohesion_energy = 0.05;
  c.time_step = 1.0e-6;
  c.end_time = end;
  c.history_interval = 1.0e-4;
  c.checkpoint_interval = 0.0;
  const double length = 0.016;  // solid fraction 0.26
  testing::add_random_gas(c, 2000, 0.4e-3, 0.6e-3, length, 0.2, 14);
  for (int axis = 0; axis < 3; ++axis) {
    for (const double side : {0.0, length}) {
      Eigen::Vector3d normal = Eigen::Vector3d::Zero();
      normal[axis] = side == 0.0 ? 1.0 : -1.0;
      Eigen::Vector3d point = Eigen::Vector3d::Zero();
      point[axis] = side;
      c.boundaries.push_back(plane_boundary(point, normal, 0, "wall"));
    }
  }
  return c;
}

TEST(ContactHistory, JkrAndEpsdRestartAndThreadBitForBit) {
  namespace fs = std::filesystem;
  const fs::path whole = testing::fresh_directory("contact_history_whole");
  const fs::path half = testing::fresh_directory("contact_history_half");
  const fs::path serial = testing::fresh_directory("contact_history_serial");
  const RunResult result = testing::quiet_run(sticky_gas(1.0e-3), whole);
  EXPECT_GT(result.contacts.contacts, 200u);  // the history is exercised
  EXPECT_GT(result.contacts.wall_contacts, 20u);
  testing::quiet_run(sticky_gas(0.5e-3), half);
  // The checkpoint keeps the pairs' rolling springs and JKR flags (its pair records carry them
  // only in runs with contact history): the continued run below needs them to agree.
  const Checkpoint saved = read_checkpoint((half / "checkpoint.bin").string());
  ASSERT_TRUE(saved.particles.contact_history);
  EXPECT_TRUE(std::any_of(saved.stepper.slips.begin(), saved.stepper.slips.end(),
                          [](const SlipRecord& s) { return s.joined != 0; }));
  EXPECT_TRUE(
      std::any_of(saved.stepper.slips.begin(), saved.stepper.slips.end(),
                  [](const SlipRecord& s) { return s.rx != 0.0 || s.ry != 0.0 || s.rz != 0.0; }));
  testing::quiet_run(sticky_gas(1.0e-3), half, (half / "checkpoint.bin").string());
  EXPECT_TRUE(testing::file_bytes(whole / "final_state.csv") ==
              testing::file_bytes(half / "final_state.csv"));
  EXPECT_TRUE(testing::file_bytes(whole / "history.csv") ==
              testing::file_bytes(half / "history.csv"));
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  testing::quiet_run(sticky_gas(1.0e-3), serial);
  omp_set_num_threads(threads);
  EXPECT_TRUE(testing::file_bytes(whole / "final_state.csv") ==
              testing::file_bytes(serial / "final_state.csv"));
}

}  // namespace
}  // namespace bondem
