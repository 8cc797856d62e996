// The case's particle list: lattice blocks that store no particle, read like the particles
// insert_lattice() makes (a decomposed run's processes walk the list instead of each holding it).
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "io/case_file.hpp"
#include "solver/engine/scene.hpp"
#include "solver/setup/insertion.hpp"
#include "solver/setup/particle_list.hpp"

namespace bondem {
namespace {

/// Whether two specs hold the same bits in every value (positions computed two ways must agree
/// exactly, or a run from the block would differ from one from the expanded list).
bool same_bits(const ParticleSpec& a, const ParticleSpec& b) {
  const auto bits = [](const Eigen::Vector3d& v, const Eigen::Vector3d& w) {
    return std::memcmp(v.data(), w.data(), sizeof(double) * 3) == 0;
  };
  return a.material == b.material && a.radius == b.radius && bits(a.position, b.position) &&
         bits(a.velocity, b.velocity) && a.temperature == b.temperature &&
         bits(a.angular_velocity, b.angular_velocity) && a.id == b.id;
}

ParticleSpec explicit_particle(double x, std::int64_t id) {
  ParticleSpec p;
  p.radius = 1e-3;
  p.position = Eigen::Vector3d(x, 0.5, 0.25);
  p.id = id;
  return p;
}

const Box kRegion{Eigen::Vector3d(0.0101, -0.003, 0.0007), Eigen::Vector3d(0.0303, 0.0111, 0.0142)};

TEST(ParticleList, ALatticeBlockReadsAsInsertLatticeBitForBit) {
  const std::vector<ParticleSpec> made = insert_lattice(kRegion, 2.1e-3, 1e-3, 2);
  const LatticeBlock block = lattice_block(kRegion, 2.1e-3, 1e-3, 2);
  ParticleList list;
  list.append(block);
  ASSERT_EQ(list.size(), made.size());
  EXPECT_EQ(list.stored_count(), 0U);
  for (std::size_t k = 0; k < made.size(); ++k) {
    ASSERT_TRUE(same_bits(list[k], made[k])) << k;
  }
}

TEST(ParticleList, KeepsTheOrderOfStoredRunsAndBlocks) {
  LatticeBlock block = lattice_block(kRegion, 2.1e-3, 1e-3, 0);
  block.velocity = Eigen::Vector3d(0.1, 0.0, -0.2);
  block.temperature = 400.0;
  const std::size_t cells = block.size();
  ParticleList list;
  list.push_back(explicit_particle(1.0, 7));
  list.append(block);
  list.append({explicit_particle(2.0, -1), explicit_particle(3.0, -1)});
  list.append(block);
  list.push_back(explicit_particle(4.0, -1));
  ASSERT_EQ(list.size(), 4 + 2 * cells);
  EXPECT_EQ(list.stored_count(), 4U);

  std::vector<ParticleSpec> expected{explicit_particle(1.0, 7)};
  for (std::size_t k = 0; k < cells; ++k) expected.push_back(block.at(k));
  expected.push_back(explicit_particle(2.0, -1));
  expected.push_back(explicit_particle(3.0, -1));
  for (std::size_t k = 0; k < cells; ++k) expected.push_back(block.at(k));
  expected.push_back(explicit_particle(4.0, -1));
  std::size_t k = 0;
  for (const ParticleSpec& p : list) {
    ASSERT_TRUE(same_bits(p, expected[k])) << k;
    ++k;
  }
  EXPECT_EQ(k, expected.size());
  EXPECT_EQ(list[cells].velocity, Eigen::Vector3d(0.1, 0.0, -0.2));
  EXPECT_EQ(list[cells].temperature, 400.0);

  // Changing one particle stores all of them, in the same order.
  list.edit(1).temperature = 500.0;
  EXPECT_EQ(list.stored_count(), list.size());
  expected[1].temperature = 500.0;
  for (std::size_t i = 0; i < expected.size(); ++i) ASSERT_TRUE(same_bits(list[i], expected[i]));
  list.expanded().pop_back();
  EXPECT_EQ(list.size(), expected.size() - 1);
  list.clear();
  EXPECT_TRUE(list.empty());
  list.expanded().push_back(explicit_particle(5.0, 9));  // filled through the vector
  ASSERT_EQ(list.size(), 1U);
  EXPECT_EQ(list[0].id, 9);
}

TEST(ParticleList, IdsOfChosenParticlesAreThoseOfTheWholeList) {
  Case c;
  c.materials.push_back(Material{});
  c.particles.push_back(explicit_particle(1.0, 40));
  c.particles.append(lattice_block(kRegion, 2.1e-3, 1e-3, 0));
  c.particles.push_back(explicit_particle(2.0, 3));
  c.particles.push_back(explicit_particle(3.0, -1));
  std::vector<std::uint32_t> every(c.particles.size());
  for (std::uint32_t i = 0; i < every.size(); ++i) every[i] = i;
  const std::vector<std::int64_t> all = particle_ids(c, every);
  // The given ids stay; the others count on from the largest given one, in list order.
  EXPECT_EQ(all.front(), 40);
  EXPECT_EQ(all[1], 41);
  EXPECT_EQ(all[all.size() - 2], 3);
  EXPECT_EQ(all.back(), 41 + static_cast<std::int64_t>(c.particles.size()) - 3);
  EXPECT_EQ(next_particle_id(c), all.back() + 1);
  const std::vector<std::uint32_t> chosen{every.back(), 5, 0, 5, every[every.size() - 2]};
  const std::vector<std::int64_t> some = particle_ids(c, chosen);
  ASSERT_EQ(some.size(), chosen.size());
  for (std::size_t k = 0; k < chosen.size(); ++k) EXPECT_EQ(some[k], all[chosen[k]]) << k;
}

/// The overlap check of one lattice block is worked out from its spacing and the periods, without
/// the grid; it must find what the grid finds over the expanded list.
TEST(ParticleList, OverlapCheckOfALatticeBlockFindsWhatTheGridFinds) {
  Domain domain;
  domain.min = Eigen::Vector3d(0.0, 0.0, 0.0);
  domain.max = Eigen::Vector3d(0.02, 0.02, 0.02);
  domain.periodic = {true, true, false};
  const double radius = 1e-3;
  struct Setting {
    Box region;
    double spacing;
    bool overlapping;  // at either limit
  };
  const std::vector<Setting> settings{
      {{Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(0.02)}, 2.0e-3, false},
      {{Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(0.02)}, 1.3e-3, true},  // neighbours
      {{Eigen::Vector3d(-6e-4, 0, 0), Eigen::Vector3d(0.02, 0.02, 0.02)},
       2.06e-3,
       true},  // across x
      {{Eigen::Vector3d(0, -8e-4, 0), Eigen::Vector3d(0.02, 0.0214, 0.02)},
       2.2e-3,
       true},  // across y
      {{Eigen::Vector3d(0, 0, -8e-4), Eigen::Vector3d(0.02, 0.02, 0.0206)},
       2.2e-3,
       false},  // z is not periodic
  };
  for (std::size_t s = 0; s < settings.size(); ++s) {
    ParticleList block;
    block.append(lattice_block(settings[s].region, settings[s].spacing, radius, 0));
    const ParticleList stored(insert_lattice(settings[s].region, settings[s].spacing, radius, 0));
    for (const double limit : {0.05, 0.3}) {
      const auto fast = find_initial_overlap(block, &domain, limit);
      const auto grid = find_initial_overlap(stored, &domain, limit);
      ASSERT_EQ(fast.has_value(), grid.has_value()) << s << " " << limit;
      EXPECT_EQ(fast.has_value(), settings[s].overlapping) << s << " " << limit;
      if (!fast) continue;
      EXPECT_EQ(fast->later, grid->later) << s;
      EXPECT_EQ(fast->earlier, grid->earlier) << s;
      EXPECT_EQ(fast->across_boundary, grid->across_boundary) << s;
      EXPECT_NEAR(fast->fraction, grid->fraction, 1e-9) << s;  // one distance, rounded two ways
    }
  }
}

/// A case file's lattice is read as a block: a process of a decomposed run holds none of its
/// particles until it walks the list for its own.
TEST(ParticleList, TheReaderKeepsALatticeAsABlock) {
  const std::string text = R"(materials:
  powder: {density: 2000, youngs_modulus: 1.0e9, poisson_ratio: 0.3}
contact: {damping_ratio: 0.1}
time: {step: 1.0e-7, end: 1.0e-6}
domain: {min: [0, 0, 0], max: [0.2, 0.2, 0.2], periodic: [true, true, false]}
particles:
  - {material: powder, radius: 0.001, position: [0.1, 0.1, 0.195]}
insert:
  - {type: lattice, region: {min: [0, 0, 0], max: [0.2, 0.2, 0.1]}, spacing: 0.002, radius: 0.001, material: powder, velocity: [0, 0, -0.5]}
)";
  const Case c = parse_case(text, "case.yaml", {});
  ASSERT_EQ(c.particles.size(), 1U + 100U * 100U * 50U);
  EXPECT_EQ(c.particles.stored_count(), 1U);
  const ParticleSpec last = c.particles[c.particles.size() - 1];
  EXPECT_DOUBLE_EQ(last.position.z(), 0.001 + 49 * 0.002);
  EXPECT_EQ(last.velocity, Eigen::Vector3d(0, 0, -0.5));
}

}  // namespace
}  // namespace bondem
