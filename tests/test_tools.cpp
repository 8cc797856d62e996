// Moving tools: a blade pushes particles with forces that balance their momentum change, and a
// spinning roller drags particles along its surface velocity.
#include <gtest/gtest.h>

#include <cmath>

#include "scene_builders.hpp"
#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"

namespace bondem {
namespace {

TEST(Tools, QuickApartTestAgreesWithTheExactGap) {
  // The kernel skips a tool when surely_apart holds; it must hold exactly when the exact gap
  // reaches the radius. Points on a grid around a box and a slanted cylinder, radius 1 mm; the
  // two agree except within rounding of the gap (1e-12 m here) of the touching distance.
  Boundary box;
  box.center = Eigen::Vector3d(0.1, -0.2, 0.3);
  box.shape = BoxShape{Eigen::Vector3d(0.002, 0.004, 0.001)};
  Boundary cylinder;
  cylinder.center = box.center;
  cylinder.shape = CylinderShape{Eigen::Vector3d(1.0, 2.0, 0.5).normalized(), 0.003};
  const double r = 1e-3;
  int apart = 0, touching = 0;
  for (const Boundary* body : {&box, &cylinder}) {
    for (int a = -12; a <= 12; ++a) {
      for (int b = -12; b <= 12; ++b) {
        for (int c = -12; c <= 12; ++c) {
          const Eigen::Vector3d point = body->center + 0.00053 * Eigen::Vector3d(a, b, c);
          const double gap = nearest_surface(*body, point).gap;
          if (std::abs(gap - r) < 1e-12) continue;
          EXPECT_EQ(surely_apart(*body, point, r), gap >= r) << a << ' ' << b << ' ' << c;
          (gap >= r ? apart : touching) += 1;
        }
      }
    }
  }
  EXPECT_GT(apart, 1000);  // both outcomes are exercised
  EXPECT_GT(touching, 1000);
}

TEST(Blade, PushesParticlesAndItsLoadBalancesTheirMomentum) {
  Case c = testing::row_on_floor(4, 0.3, 2e-7);
  Boundary blade;
  blade.name = "blade";
  blade.center = Eigen::Vector3d(0.0024, 0.005, 0.003);  // front face 0.1 mm behind the row
  blade.shape = BoxShape{Eigen::Vector3d(0.0005, 0.01, 0.003)};
  blade.motion.keys = {{0.0, Eigen::Vector3d(0.1, 0.0, 0.0)}};
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
  // Velocity Verlet changes momentum by dt/2 (F_k + F_k+1) per step: the trapezoid rule over the
  // forces of successive evaluations. With a frictionless floor and pair forces cancelling in
  // pairs, only the blade pushes along x.
  double impulse = 0.0;
  double previous = -stepper.boundary_loads()[1].force.x();
  for (int s = 0; s < 50000; ++s) {  // 10 ms: the blade travels 0.9 mm into the row
    stepper.step();
    const double current =
        -stepper.boundary_loads()[1].force.x();  // force of the blade on particles
    impulse += 0.5 * c.time_step * (previous + current);
    previous = current;
  }
  EXPECT_GT(impulse, 0.0);
  EXPECT_NEAR(momentum_x() - start, impulse, 1e-9 * std::abs(impulse) + 1e-15);
  double front = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) front = std::max(front, p.x[i]);
  EXPECT_GT(front, 0.004 + 0.0021 * 3 + 1e-4) << "the push must reach the last particle";
}

TEST(Roller, SpinDragsAParticleAlongItsSurface) {
  Case c = testing::row_on_floor(1, 0.3, 2e-7);
  c.contact.friction = 0.5;
  Boundary roller;
  roller.name = "roller";
  // Spinning about +y at 50 rad/s: the bottom of the roller moves toward -x.
  roller.shape = CylinderShape{Eigen::Vector3d::UnitY(), 0.003};
  roller.motion.axis = Eigen::Vector3d::UnitY();
  roller.motion.spin = 50.0;
  roller.center = Eigen::Vector3d(0.004, 0.005, 0.002 + 0.003 - 2e-6);  // pressing lightly
  c.boundaries.push_back(roller);
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  for (int s = 0; s < 20000; ++s) stepper.step();
  EXPECT_LT(scene.particles.vx[0], -1e-3);
  EXPECT_LT(scene.particles.x[0], 0.004);
}

}  // namespace
}  // namespace bondem
