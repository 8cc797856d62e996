// The per-particle displacement (Particles::dx, dy, dz): summed in the drift from the position's
// own increments, so x - x0 up to rounding and unwrapped across periodic boundaries; carried by
// reorders and checkpoints; written to the VTK particle files as "displacement".
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "io/case_file.hpp"
#include "io/checkpoint.hpp"
#include "io/vtk_output.hpp"
#include "run_helpers.hpp"
#include "scene_builders.hpp"
#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"

namespace bondem {
namespace {

namespace fs = std::filesystem;

/// Far below any displacement these tests produce (1e-4 m and more), far above the rounding of
/// a few thousand increments of millimetre-sized coordinates (about 1e-15 m).
constexpr double kRounding = 1e-12;

/// One particle of radius 0.1 mm at @p position moving at @p velocity.
Case single_particle(const Eigen::Vector3d& position, const Eigen::Vector3d& velocity) {
  Case c = testing::soft_case(0.0);
  c.particles.push_back({0, 1e-4, position, velocity});
  c.time_step = 1e-5;
  c.vtk_interval = 1.0;  // the displacement is tracked for VTK frames
  return c;
}

/// A settling gas of 500 particles in a 6 mm box, periodic in x and y, walls below and above,
/// gravity along -z, reordered at every list build: particles collide, cross the periodic faces
/// and change index.
Case periodic_gas() {
  Case c = testing::soft_case(0.1);
  c.materials[0].youngs_modulus = 5e8;
  testing::add_random_gas(c, 500, 0.1e-3, 0.25e-3, 0.006, 2.0, 23);
  c.domain->periodic = {true, true, false};
  const bool open[6] = {true, true, true, true, false, false};
  c.boundaries = box_container(c.domain->min, c.domain->max, 0, open);
  c.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  c.time_step = 5e-8;
  c.reorder_interval = 1;
  c.vtk_interval = 1e-5;  // the displacement is tracked for VTK frames
  return c;
}

// The displacement's one reader is the VTK writer: a run without frames does not pay its 24 B a
// particle, and still moves the same (the field is only a sum of the drift's increments).
TEST(Displacement, TrackedOnlyWhenVtkFramesAreWritten) {
  Case c = single_particle(Eigen::Vector3d(1e-3, 2e-3, 3e-3), Eigen::Vector3d(0.3, 0.0, 0.0));
  Case without = c;
  without.vtk_interval = 0.0;
  Scene tracked = build_scene(c);
  Scene plain = build_scene(without);
  EXPECT_EQ(tracked.particles.dx.size(), 1u);
  EXPECT_TRUE(plain.particles.dx.empty());
  Stepper a(tracked);
  Stepper b(plain);
  for (int s = 0; s < 100; ++s) {
    a.step();
    b.step();
  }
  EXPECT_EQ(tracked.particles.x, plain.particles.x);
  EXPECT_TRUE(plain.particles.dx.empty());
}

TEST(Displacement, FreeFlightUnderGravityIsPositionMinusStart) {
  const Eigen::Vector3d x0(1e-3, 2e-3, 3e-3), v0(0.3, -0.2, 0.5);
  Case c = single_particle(x0, v0);
  c.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  const Particles& p = scene.particles;
  EXPECT_EQ(p.dx[0], 0.0);
  for (int s = 0; s < 1000; ++s) stepper.step();
  const double t = stepper.time();
  const Eigen::Vector3d moved = v0 * t + 0.5 * c.gravity * t * t;  // exact for velocity Verlet
  EXPECT_NEAR(p.dx[0], p.x[0] - x0.x(), kRounding);
  EXPECT_NEAR(p.dy[0], p.y[0] - x0.y(), kRounding);
  EXPECT_NEAR(p.dz[0], p.z[0] - x0.z(), kRounding);
  EXPECT_NEAR(p.dx[0], moved.x(), kRounding);
  EXPECT_NEAR(p.dz[0], moved.z(), kRounding);
  EXPECT_LT(p.dz[0], v0.z() * t - 4.0 * t * t);  // gravity has bent the path down
}

TEST(Displacement, CrossingAPeriodicBoundaryDoesNotJump) {
  // 4 mm periodic in x at 1.5 m/s for 5 ms: 7.5 mm, nearly two box lengths.
  const double speed = 1.5;
  Case c = single_particle(Eigen::Vector3d(3.5e-3, 2e-3, 2e-3), Eigen::Vector3d(speed, 0, 0));
  Domain domain;
  domain.max = Eigen::Vector3d::Constant(4e-3);
  domain.periodic = {true, false, false};
  c.domain = domain;
  c.time_step = 1e-6;
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  const Particles& p = scene.particles;
  double previous = 0.0;
  for (int s = 0; s < 5000; ++s) {
    stepper.step();
    // Every step adds v dt, also the steps whose list build wraps the coordinate.
    ASSERT_NEAR(p.dx[0] - previous, speed * c.time_step, 1e-15) << "step " << s;
    previous = p.dx[0];
  }
  EXPECT_NEAR(p.dx[0], speed * stepper.time(), kRounding);
  EXPECT_EQ(p.dy[0], 0.0);
  EXPECT_EQ(p.dz[0], 0.0);
  // The coordinate itself was wrapped (twice): it differs from x0 + dx by whole box lengths.
  EXPECT_GE(p.x[0], 0.0);
  EXPECT_LT(p.x[0], 4e-3);
  EXPECT_NEAR(3.5e-3 + p.dx[0] - p.x[0], 2 * 4e-3, kRounding);
}

TEST(Displacement, FollowsItsParticleThroughReordersAndPeriodicWraps) {
  const Case c = periodic_gas();
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  const Particles& p = scene.particles;
  const std::int64_t builds = stepper.neighbors().build_count();
  for (int s = 0; s < 16000; ++s) stepper.step();
  ASSERT_GT(stepper.neighbors().build_count(), builds + 5) << "the test must cross reorders";
  const Eigen::Vector3d length = scene.domain.length();
  std::size_t moved_index = 0, wrapped = 0;
  for (std::size_t k = 0; k < p.size(); ++k) {
    const auto id = static_cast<std::size_t>(p.id[k]);
    moved_index += id != k ? 1 : 0;
    const Eigen::Vector3d start = c.particles[id].position;
    const double d[3] = {p.dx[k], p.dy[k], p.dz[k]};
    const double now[3] = {p.x[k], p.y[k], p.z[k]};
    for (int a = 0; a < 3; ++a) {
      // x - x0 - d is 0 on the walled axis and a whole number of box lengths on periodic ones.
      const double periods = (now[a] - start[a] - d[a]) / length[a];
      const double whole = a < 2 ? std::round(periods) : 0.0;
      EXPECT_NEAR(periods, whole, kRounding / length[a]) << "id " << id << " axis " << a;
      wrapped += whole != 0.0 ? 1 : 0;
    }
  }
  EXPECT_GT(moved_index, p.size() / 2) << "reorders must have moved most particles";
  EXPECT_GT(wrapped, 10u) << "particles must have crossed the periodic faces";
}

TEST(Displacement, RestartContinuesItExactly) {
  const fs::path whole = testing::fresh_directory("displacement_whole");
  const fs::path half = testing::fresh_directory("displacement_half");
  Case c = periodic_gas();
  c.end_time = 2e-4;  // 4000 steps
  c.vtk_interval = 1e-4;
  testing::quiet_run(c, whole);
  c.end_time = 1e-4;
  testing::quiet_run(c, half);
  c.end_time = 2e-4;
  testing::quiet_run(c, half, (half / "checkpoint.bin").string());
  const Checkpoint a = read_checkpoint((whole / "checkpoint.bin").string());
  const Checkpoint b = read_checkpoint((half / "checkpoint.bin").string());
  // Without the field in the checkpoint the continued run would start again from zero.
  const auto largest =
      std::max_element(a.particles.dz.begin(), a.particles.dz.end(),
                       [](double l, double r) { return std::abs(l) < std::abs(r); });
  ASSERT_GT(std::abs(*largest), 1e-5);
  EXPECT_TRUE(a.particles.dx == b.particles.dx);
  EXPECT_TRUE(a.particles.dy == b.particles.dy);
  EXPECT_TRUE(a.particles.dz == b.particles.dz);
  EXPECT_TRUE(testing::file_bytes(whole / "particles_000002.vtp") ==
              testing::file_bytes(half / "particles_000002.vtp"));
}

TEST(Displacement, VtkParticleFilesHoldIt) {
  const fs::path directory = testing::fresh_directory("displacement_vtk");
  Case c = periodic_gas();
  c.domain->periodic = {false, false, false};  // so that x - x0 is the displacement itself
  const bool open[6] = {false, false, false, false, false, false};
  c.boundaries = box_container(c.domain->min, c.domain->max, 0, open);
  c.end_time = 2e-4;
  c.vtk_interval = 1e-4;
  testing::quiet_run(c, directory);
  const VtpContents first = read_vtp((directory / "particles_000000.vtp").string());
  const VtpContents last = read_vtp((directory / "particles_000002.vtp").string());
  for (const VtpContents* file : {&first, &last}) {
    const VtpArray* displacement = file->point_array("displacement");
    ASSERT_NE(displacement, nullptr);
    EXPECT_EQ(displacement->type, "Float64");
    EXPECT_EQ(displacement->components, 3);
    ASSERT_EQ(displacement->values.size(), 3 * c.particles.size());
  }
  EXPECT_TRUE(std::all_of(first.point_array("displacement")->values.begin(),
                          first.point_array("displacement")->values.end(),
                          [](double d) { return d == 0.0; }));
  const std::vector<double>& d = last.point_array("displacement")->values;
  const std::vector<double>& ids = last.point_array("id")->values;
  double largest = 0.0;
  for (std::size_t k = 0; k < last.points.size(); ++k) {
    const Eigen::Vector3d start = c.particles[static_cast<std::size_t>(ids[k])].position;
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(d[3 * k + static_cast<std::size_t>(a)], last.points[k][a] - start[a], kRounding);
      largest = std::max(largest, std::abs(d[3 * k + static_cast<std::size_t>(a)]));
    }
  }
  EXPECT_GT(largest, 1e-5);
}

TEST(Displacement, VersionThreeCheckpointIsRefused) {
  // Version 3 checkpoints have no displacement: the version check refuses them rather than
  // reading their thermal or wall arrays as displacements.
  const fs::path directory = testing::fresh_directory("displacement_version");
  Case c = single_particle(Eigen::Vector3d(1e-3, 1e-3, 1e-3), Eigen::Vector3d(0.1, 0, 0));
  c.time_step = 5e-7;
  c.end_time = 1e-4;
  testing::quiet_run(c, directory);
  std::string bytes = testing::file_bytes(directory / "checkpoint.bin");
  ASSERT_EQ(static_cast<std::uint8_t>(bytes[8]), kCheckpointVersion);
  bytes[8] = 3;
  const fs::path old = directory / "version3.bin";
  std::ofstream(old, std::ios::binary) << bytes;
  c.end_time = 2e-4;
  try {
    testing::quiet_run(c, directory / "resumed", old.string());
    FAIL() << "a version-3 checkpoint was accepted";
  } catch (const CaseError& e) {
    EXPECT_NE(std::string(e.what()).find("checkpoint format version 3, this bondem reads version " +
                                         std::to_string(kCheckpointVersion)),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace bondem
