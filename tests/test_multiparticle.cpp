// Multi-particle physics through the full stepper: identical bytes at 1 and 2 threads, energy
// conservation of an elastic gas, a settled column's wall force, and bonds inside a crowd.
#include <gtest/gtest.h>
#include <omp.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "all_pairs.hpp"
#include "io/case_file.hpp"
#include "io/run.hpp"
#include "run_helpers.hpp"
#include "scene_builders.hpp"
#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"

namespace bondem {
namespace {

/// Runs @p c with @p threads threads into a fresh directory; returns final_state.csv's bytes.
std::string final_state_with(const Case& c, int threads, const std::string& name) {
  const auto directory = testing::test_root() / name;
  std::filesystem::remove_all(directory);
  const int saved = omp_get_max_threads();
  omp_set_num_threads(threads);
  testing::quiet_run(c, directory);
  omp_set_num_threads(saved);
  return testing::file_bytes(directory / "final_state.csv");
}

TEST(Determinism, SameBytesAtOneAndTwoThreads) {
  // Above kMinParallelParticles so that the parallel loops really split; gravity, walls, a dense
  // bed and reordering all take part.
  const Case c =
      load_case(BONDEM_CASES_DIR "/powder_bed_packing_ci.yaml",
                {"insert.0.count=4000", "domain.max.2=0.09", "walls.0.max.2=0.09",
                 "insert.0.region.max.2=0.085", "time.end=0.02", "contact.damping_ratio=0.1"});
  const std::string one = final_state_with(c, 1, "det1");
  const std::string two = final_state_with(c, 2, "det2");
  ASSERT_GT(one.size(), 4000u * 100u);
  EXPECT_TRUE(one == two) << "final_state.csv differs between 1 and 2 threads";
}

/// Kinetic plus Hertz elastic energy (2/5) K delta^(5/2) of every overlapping pair.
double total_energy(const Scene& scene, const Stepper& stepper) {
  const Particles& p = scene.particles;
  double elastic = 0.0;
  for (const auto& [i, j] : find_pairs_all(p, scene.domain, 0.0)) {
    double d[3] = {p.x[j] - p.x[i], p.y[j] - p.y[i], p.z[j] - p.z[i]};
    for (int a = 0; a < 3; ++a) {
      const double length = scene.domain.length()[a];
      if (scene.domain.periodic[a]) d[a] -= length * std::nearbyint(d[a] / length);
    }
    const double overlap =
        p.radius[i] + p.radius[j] - std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    const double k = hertz_stiffness(scene.pair(0, 0).effective_modulus,
                                     effective_radius(p.radius[i], p.radius[j]));
    elastic += 0.4 * k * std::pow(overlap, 2.5);
  }
  return stepper.kinetic_energy() + elastic;
}

TEST(Energy, ElasticGasConservesEnergy) {
  // xi_con = 0, no gravity, fully periodic: only the integrator changes the energy. Velocity
  // Verlet is symplectic for smooth forces; the Hertz force is not smooth at first touch, which
  // costs O((dt / t_contact)^2) per collision without accumulating a trend. With 2e-7 s against a
  // contact time above 3e-5 s (150 steps) a drift bound of 0.1 % over 3000 steps leaves a margin
  // of several times what a correct integrator shows; a wrong sign or a missing half kick gives
  // percent-level drift within a few hundred steps.
  Case c = testing::soft_case(0.0);
  testing::add_random_gas(c, 2500, 0.2e-3, 0.5e-3, 0.012, 1.0, 99);
  c.domain->periodic = {true, true, true};
  c.time_step = 2e-7;
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  const double start = total_energy(scene, stepper);
  double worst = 0.0;
  std::size_t collisions_seen = 0;
  for (int s = 1; s <= 3000; ++s) {
    stepper.step();
    collisions_seen = std::max(collisions_seen, stepper.contacts().contacts);
    if (s % 100 == 0) worst = std::max(worst, std::abs(total_energy(scene, stepper) / start - 1.0));
  }
  EXPECT_GT(collisions_seen, 10u) << "the gas must collide for the test to mean anything";
  EXPECT_LT(worst, 1e-3);
}

TEST(Walls, SettledColumnWeighsOnTheFloor) {
  // Frictionless spheres (no tangential force yet) in a periodic column on a floor: once at rest
  // the floor carries the whole weight. Residual motion after settling perturbs the sum by
  // m * a, far below the 1 % asked for.
  Case c = testing::soft_case(0.7);
  c.materials.push_back({"wall", 7800.0, 5.0e6, 0.3});
  c.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  FillRequest fill;
  fill.region = Box{Eigen::Vector3d::Zero(), Eigen::Vector3d(0.008, 0.008, 0.012)};
  fill.radius.kind = RadiusDistribution::Kind::kUniform;
  fill.radius.min = 0.3e-3;
  fill.radius.max = 0.5e-3;
  fill.count = 600;
  fill.seed = 7;
  c.particles = insert_random_fill(fill);
  Domain d;
  d.max = Eigen::Vector3d(0.008, 0.008, 0.014);
  d.periodic = {true, true, false};
  c.domain = d;
  c.boundaries.push_back(
      plane_boundary(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), 1, "floor"));
  c.time_step = 1.5e-6;
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  double weight = 0.0;
  for (const double m : scene.particles.mass) weight += m * 9.81;
  for (int s = 0; s < 100000 && (s < 20000 || stepper.kinetic_energy() > 1e-12); ++s)
    stepper.step();
  const Eigen::Vector3d floor = stepper.boundary_loads()[0].force;
  EXPECT_NEAR(-floor.z(), weight, 0.01 * weight);  // the particles push the floor down
  EXPECT_NEAR(floor.x(), 0.0, 1e-6 * weight);
}

TEST(Bonds, PairInsideACrowdSettlesAtEquilibrium) {
  // The paper's pair (r = 1 mm, delta_eq = 50 um) colliding at 1.5 v_crit across a periodic
  // boundary, among resting particles of a lattice that it never touches: the cell list, the
  // periodic image and the two-pass gather must deliver exactly the two-particle physics.
  Case c = load_case(BONDEM_CASES_DIR "/paper_5_2.yaml");
  c.particles.clear();
  const double v = 1.5 * 2.5744;
  for (int k = 0; k < 40; ++k) {  // bystanders on a loose lattice, 4 mm apart
    ParticleSpec p;
    p.radius = 1e-3;
    p.position = Eigen::Vector3d(
        0.002 + 0.004 * (k % 5), 0.002 + 0.004 * ((k / 5) % 4),
        0.006 + 0.004 * (k / 20));  // NOLINT(bugprone-integer-division): layers of 20
    c.particles.push_back(p);
  }
  ParticleSpec left, right;
  left.radius = right.radius = 1e-3;
  left.position = Eigen::Vector3d(0.019, 0.01, 0.002);  // touching across the periodic x boundary
  right.position = Eigen::Vector3d(0.001, 0.01, 0.002);
  left.velocity = Eigen::Vector3d(0.5 * v, 0.0, 0.0);
  right.velocity = Eigen::Vector3d(-0.5 * v, 0.0, 0.0);
  c.particles.push_back(left);
  c.particles.push_back(right);
  Domain d;
  d.max = Eigen::Vector3d(0.02, 0.02, 0.02);
  d.periodic = {true, true, true};
  c.domain = d;
  c.skin = 1e-4;
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  const auto steps = static_cast<int>(c.end_time / c.time_step);
  for (int s = 0; s < steps; ++s) stepper.step();
  EXPECT_EQ(stepper.contacts().contacts, 1u);
  EXPECT_EQ(stepper.contacts().bonds, 1u);
  EXPECT_NEAR(stepper.contacts().max_overlap, 5e-5, 1e-3 * 5e-5);
}

}  // namespace
}  // namespace bondem
