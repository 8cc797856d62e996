// Tangential contact, rolling resistance and rotation: a sphere on an incline, a sphere rolling
// to rest, tangential history across reordering, and determinism with friction.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>

#include "scene_builders.hpp"
#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"

namespace bondem {
namespace {

constexpr double kG = 9.81;
constexpr double kRadius = 1e-3;

/// One sphere resting on a floor (normal +z) with gravity tilted by theta about y, so that the
/// floor is an incline rising against +x.
Case sphere_on_floor(double theta, double friction, double rolling_friction) {
  Case c = testing::soft_case(0.3);
  c.materials[0].youngs_modulus = 1e8;
  c.contact.friction = friction;
  c.contact.rolling_friction = rolling_friction;
  c.gravity = Eigen::Vector3d(kG * std::sin(theta), 0.0, -kG * std::cos(theta));
  ParticleSpec p;
  p.radius = kRadius;
  p.position = Eigen::Vector3d(0.0, 0.0, kRadius);
  c.particles.push_back(p);
  c.boundaries.push_back(
      plane_boundary(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), 0, "floor"));
  Domain d;
  d.min = Eigen::Vector3d(-0.05, -0.01, -0.01);
  d.max = Eigen::Vector3d(0.05, 0.01, 0.01);
  c.domain = d;
  c.time_step = 2e-7;
  return c;
}

/// Distance slid down the incline in @p duration.
double slide_distance(const Case& c, double duration) {
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  const auto steps = static_cast<int>(duration / c.time_step);
  for (int s = 0; s < steps; ++s) stepper.step();
  return scene.particles.x[0];
}

// Rolling is blocked by mu_r = 1 (the rolling torque limit r N exceeds the gravity torque
// r N tan(theta) for tan(theta) < 1), so the sphere behaves like a block: it sticks while
// tan(theta) <= mu and slides with a = g (sin - mu cos) above.
TEST(Incline, SticksBelowFrictionAngle) {
  const double mu = 0.3;
  const double x = slide_distance(sphere_on_floor(std::atan(0.9 * mu), mu, 1.0), 0.02);
  // Sticking still stretches the tangential spring: creep is bounded by mu N / k_t, a few nm.
  EXPECT_LT(std::abs(x), 1e-3 * kRadius) << "x = " << x;
}

TEST(Incline, SlidesAboveFrictionAngle) {
  const double mu = 0.3;
  const double theta = std::atan(1.1 * mu);
  const double duration = 0.02;
  const double x = slide_distance(sphere_on_floor(theta, mu, 1.0), duration);
  const double expected = 0.5 * kG * (std::sin(theta) - mu * std::cos(theta)) * duration * duration;
  // The first ~0.1 ms settle the normal contact and stretch the spring to the Coulomb limit;
  // they shift the slide by well under 2 %.
  EXPECT_NEAR(x, expected, 0.02 * expected);
}

TEST(Rolling, SphereDeceleratesAsTheRollingModelPredicts) {
  // Pure rolling at v0 on a level floor: the constant torque mu_r r N decelerates the sphere
  // (translation and rotation together, I = 2/5 m r^2) at a = 5/7 mu_r g.
  const double mu_r = 0.04;
  Case c = sphere_on_floor(0.0, 0.5, mu_r);
  const double v0 = 0.05;
  c.particles.edit(0).velocity = Eigen::Vector3d(v0, 0.0, 0.0);
  c.particles.edit(0).position.z() =
      kRadius - 1.0e-7;  // about the static overlap: no bouncing start
  Scene scene = build_scene(c);
  scene.particles.wy[0] = v0 / kRadius;  // rolling without slipping toward +x
  Stepper stepper(scene);
  const double duration = 0.05;
  const auto steps = static_cast<int>(duration / c.time_step);
  for (int s = 0; s < steps; ++s) stepper.step();
  const double expected = v0 - 5.0 / 7.0 * mu_r * kG * duration;
  ASSERT_GT(expected, 0.0);
  // The normal contact oscillates briefly at the start (damped): 1 % of the velocity lost.
  EXPECT_NEAR(scene.particles.vx[0], expected, 0.01 * (v0 - expected));
  // Still rolling, not sliding: the contact point is at rest.
  EXPECT_NEAR(scene.particles.vx[0] - kRadius * scene.particles.wy[0], 0.0, 1e-4 * v0);
}

/// A frictional, dense, polydisperse gas in a periodic box: many sticking and sliding contacts.
Case frictional_gas(int reorder_interval, double skin = 2e-5) {
  Case c = testing::soft_case(0.2);
  c.materials[0].youngs_modulus = 5e8;
  c.contact.friction = 0.5;
  c.contact.rolling_friction = 0.05;
  testing::add_random_gas(c, 2500, 0.2e-3, 0.5e-3, 0.0115, 1.0, 31);
  c.domain->periodic = {true, true, true};
  c.time_step = 1e-7;
  c.skin = skin;
  c.reorder_interval = reorder_interval;
  return c;
}

TEST(TangentialHistory, SameWithAndWithoutReorderingAndRebuilds) {
  // One run rebuilds its list often (small skin) and reorders the particles at every rebuild; the
  // other has a skin wide enough never to rebuild in 1500 steps (1 m/s x 0.15 ms < skin / 2).
  // Only the order of floating-point sums differs (1e-16 relative, growing slowly over a short
  // run); a spring lost, misplaced or sign-flipped at a rebuild would change forces at O(1).
  Scene sorted = build_scene(frictional_gas(1, 2e-5));
  Scene unsorted = build_scene(frictional_gas(0, 4e-4));
  Stepper a(sorted);
  Stepper b(unsorted);
  std::int64_t contacts_with_history = 0;
  for (int s = 0; s < 1500; ++s) {
    a.step();
    b.step();
  }
  EXPECT_GT(a.neighbors().build_count(), 5);
  EXPECT_EQ(b.neighbors().build_count(), 1);
  std::vector<std::size_t> index_of(unsorted.particles.size());
  for (std::size_t k = 0; k < unsorted.particles.size(); ++k) {
    index_of[static_cast<std::size_t>(unsorted.particles.id[k])] = k;
  }
  double worst = 0.0;
  for (std::size_t k = 0; k < sorted.particles.size(); ++k) {
    const std::size_t m = index_of[static_cast<std::size_t>(sorted.particles.id[k])];
    worst = std::max(worst, std::abs(sorted.particles.wz[k] - unsorted.particles.wz[m]));
    worst = std::max(worst, std::abs(sorted.particles.vx[k] - unsorted.particles.vx[m]));
  }
  for (const double s : a.pair_history().sx) contacts_with_history += s != 0.0 ? 1 : 0;
  EXPECT_GT(contacts_with_history, 100);
  EXPECT_LT(worst, 1e-9);
}

TEST(TangentialHistory, ByteIdenticalAtOneAndTwoThreads) {
  const auto run = [](int threads) {
    const int saved = omp_get_max_threads();
    omp_set_num_threads(threads);
    Scene scene = build_scene(frictional_gas(5));
    Stepper stepper(scene);
    for (int s = 0; s < 600; ++s) stepper.step();
    omp_set_num_threads(saved);
    return scene.particles;
  };
  const Particles one = run(1);
  const Particles two = run(2);
  EXPECT_TRUE(one.x == two.x && one.vx == two.vx && one.wx == two.wx && one.wz == two.wz);
}

}  // namespace
}  // namespace bondem
