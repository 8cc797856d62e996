// Verlet lists of the analytic boundaries (boundary_candidates.hpp): a step tests only the
// particles a boundary can reach, and a boundary that moves toward particles out of its reach is
// gathered again before it meets them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>

#include "scene_builders.hpp"
#include "solver/engine/boundary_candidates.hpp"
#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"

namespace bondem {
namespace {

TEST(BoundaryCandidates, NearListsHoldEveryParticleWithinReachAndNoFarOne) {
  // A random gas in a 10 mm cube with a floor plane, a box, a slanted cylinder and a sphere. Every
  // particle whose exact gap to a boundary is within its radius plus the list's margin (contact
  // range + 1.5 skins) must be listed, in ascending order; every one clearly beyond must not,
  // or the lists would not narrow anything. Gaps within 1e-12 m of the margin are left out
  // (rounding of the quick test).
  Case c = testing::soft_case(0.3);
  testing::add_random_gas(c, 3000, 0.1e-3, 0.3e-3, 0.01, 0.0, 7);
  c.skin = 0.05e-3;
  c.boundaries.push_back(
      plane_boundary(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), 0, "floor"));
  Boundary box;
  box.center = Eigen::Vector3d(0.003, 0.004, 0.005);
  box.shape = BoxShape{Eigen::Vector3d(0.001, 0.002, 0.0015)};
  c.boundaries.push_back(box);
  Boundary cylinder;
  cylinder.center = Eigen::Vector3d(0.006, 0.006, 0.004);
  cylinder.shape = CylinderShape{Eigen::Vector3d(1.0, 2.0, 0.5).normalized(), 0.0012};
  c.boundaries.push_back(cylinder);
  Boundary ball;
  ball.center = Eigen::Vector3d(0.007, 0.002, 0.007);
  ball.shape = SphereShape{0.0015};
  c.boundaries.push_back(ball);
  const Scene scene = build_scene(c);
  std::vector<BoundaryCandidates> candidates;
  build_boundary_candidates(scene, candidates);
  ASSERT_EQ(candidates.size(), scene.boundaries.size());
  const Particles& p = scene.particles;
  const double margin = scene.contact_range + kBoundaryCandidateMargin * scene.skin;
  for (std::size_t b = 0; b < scene.boundaries.size(); ++b) {
    const std::vector<std::uint32_t>& near = candidates[b].near;
    EXPECT_TRUE(std::adjacent_find(near.begin(), near.end(), std::greater_equal<>()) == near.end())
        << "boundary " << b << ": not strictly ascending";
    int within = 0, beyond = 0;
    for (std::size_t i = 0; i < p.size(); ++i) {
      const double gap =
          nearest_surface(scene.boundaries[b], Eigen::Vector3d(p.x[i], p.y[i], p.z[i])).gap;
      const double reach = p.radius[i] + margin;
      if (std::abs(gap - reach) < 1e-12) continue;
      const bool listed = std::binary_search(near.begin(), near.end(), i);
      EXPECT_EQ(listed, gap < reach) << "boundary " << b << ", particle " << i << ", gap " << gap;
      (gap < reach ? within : beyond) += 1;
    }
    EXPECT_GT(within, 10) << "boundary " << b;  // both outcomes are exercised
    EXPECT_GT(beyond, 1000) << "boundary " << b;
  }
}

TEST(BoundaryCandidates, AWallStartingOutOfReachStillMeetsTheParticles) {
  // A wall (a box face) starts 1 mm behind a sphere resting on a floor, ten skins out of the
  // list's reach, and moves toward it at 0.5 m/s. The sphere does not move until the wall
  // arrives, so no displacement rebuilds the lists: the wall's own travel must gather it again.
  // It pushes the sphere: the sphere ends ahead of where it started and the wall carries load.
  Case c = testing::row_on_floor(1, 0.3, 2e-7);
  c.skin = 0.05e-3;
  Boundary wall;
  wall.name = "wall";
  const double start_x = 0.004;  // the sphere's centre
  wall.center = Eigen::Vector3d(start_x - 1e-3 - 1e-3 - 0.5e-3, 0.005, 0.003);  // face 1 mm away
  wall.shape = BoxShape{Eigen::Vector3d(0.5e-3, 0.01, 0.003)};
  wall.motion.keys = {{0.0, Eigen::Vector3d(0.5, 0.0, 0.0)}};
  c.boundaries.push_back(wall);
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  const Particles& p = scene.particles;
  double largest_push = 0.0;
  for (int s = 0; s < 15000; ++s) {  // 3 ms: the wall travels 1.5 mm, 0.5 mm into the sphere
    stepper.step();
    largest_push = std::max(largest_push, -stepper.boundary_loads()[1].force.x());
  }
  EXPECT_GT(largest_push, 0.0) << "the wall never touched the sphere";
  EXPECT_GT(p.x[0], start_x + 0.4e-3) << "the wall passed through the sphere";
}

}  // namespace
}  // namespace bondem
