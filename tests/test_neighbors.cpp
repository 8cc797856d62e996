// The cell-list Verlet list against the all-pairs oracle, on polydisperse (5:1) configurations,
// with and without periodic axes, after many steps of motion and rebuilds.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <array>
#include <random>
#include <set>

#include "all_pairs.hpp"
#include "scene_builders.hpp"
#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"

namespace bondem {
namespace {

using PairSet = std::set<std::pair<std::int64_t, std::int64_t>>;

/// Pairs of the list whose particles currently overlap (by id, smaller id first).
PairSet listed_contacts(const Particles& p, const NeighborList& list, double skin_of_interest,
                        const Domain& domain) {
  PairSet out;
  const Eigen::Vector3d length = domain.length();
  list.for_each_pair([&](std::size_t i, std::size_t j, std::uint32_t k) {
    const Eigen::Vector3d d = list.separation(p, i, j, k);
    // The stored image must be the minimum image.
    for (int a = 0; a < 3; ++a) {
      if (domain.periodic[a]) {
        EXPECT_LE(std::abs(d[a]), 0.5 * length[a]);
      }
    }
    if (d.norm() < p.radius[i] + p.radius[j] + skin_of_interest) {
      out.insert(std::minmax(p.id[i], p.id[j]));
    }
  });
  return out;
}

PairSet oracle(const Particles& p, const Domain& domain, double skin) {
  PairSet out;
  for (const auto& [i, j] : find_pairs_all(p, domain, skin))
    out.insert(std::minmax(p.id[i], p.id[j]));
  return out;
}

class NeighborOracle : public ::testing::TestWithParam<std::array<bool, 3>> {};

TEST_P(NeighborOracle, MatchesAllPairsAfterMotion) {
  Case c = testing::soft_case(0.0);
  c.materials[0].youngs_modulus = 5e8;  // stiff enough that 2 m/s impacts stay small overlaps
  // Dense enough for many contacts, 5:1 size ratio, fast enough to cross cells and boundaries.
  testing::add_random_gas(c, 2500, 0.1e-3, 0.5e-3, 0.012, 2.0, 17);
  c.domain->periodic = GetParam();
  if (!c.domain->any_periodic()) {
    bool open[6] = {false, false, false, false, false, false};
    c.boundaries = box_container(c.domain->min, c.domain->max, 0, open);
  }
  c.skin = 0.05e-3;
  c.time_step = 2e-7;
  c.reorder_interval = 3;  // reorder often to exercise it
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  const Particles& p = scene.particles;
  // Right after a build the list is exactly the oracle's pairs within r_i + r_j + skin.
  EXPECT_EQ(listed_contacts(p, stepper.neighbors(), c.skin, scene.domain),
            oracle(p, scene.domain, c.skin));
  std::int64_t builds = stepper.neighbors().build_count();
  for (int s = 1; s <= 600; ++s) {
    stepper.step();
    if (s % 20 == 0) {
      // Between builds every actual contact must be in the list.
      const PairSet truth = oracle(p, scene.domain, 0.0);
      const PairSet listed = listed_contacts(p, stepper.neighbors(), 0.0, scene.domain);
      ASSERT_EQ(listed, truth) << "step " << s;
      ASSERT_FALSE(truth.empty());
    }
  }
  EXPECT_GT(stepper.neighbors().build_count(), builds + 5)
      << "the test must cross several rebuilds";
}

INSTANTIATE_TEST_SUITE_P(Boundaries, NeighborOracle,
                         ::testing::Values(std::array<bool, 3>{false, false, false},
                                           std::array<bool, 3>{true, true, true},
                                           std::array<bool, 3>{true, false, true}));

TEST(NeighborList, ReorderingKeepsIdsAndState) {
  Case c = testing::soft_case(0.0);
  testing::add_random_gas(c, 3000, 0.1e-3, 0.5e-3, 0.012, 1.0, 5);
  Scene scene = build_scene(c);
  const Particles before = scene.particles;
  NeighborList list;
  list.build(scene.particles, scene.domain, 1e-4, true);
  const Particles& after = scene.particles;
  ASSERT_EQ(after.size(), before.size());
  std::vector<int> seen(before.size(), 0);
  for (std::size_t k = 0; k < after.size(); ++k) {
    const auto id = static_cast<std::size_t>(after.id[k]);
    ++seen[id];
    EXPECT_EQ(after.x[k], before.x[id]);
    EXPECT_EQ(after.vz[k], before.vz[id]);
    EXPECT_EQ(after.radius[k], before.radius[id]);
  }
  for (int count : seen) EXPECT_EQ(count, 1);
}

// The kernels' walks must see the same pairs as for_each_pair: pass 1 in list order with every
// pair of a block prepared before any is evaluated, pass 2 every pair of a particle exactly once,
// its own row first, each part in list order.
TEST(NeighborList, BlockAndPerParticleWalksMatchThePairWalk) {
  Case c = testing::soft_case(0.0);
  testing::add_random_gas(c, 1500, 0.1e-3, 0.5e-3, 0.012, 1.0, 11);
  c.domain->periodic = {true, false, true};
  Scene scene = build_scene(c);
  NeighborList list;
  list.build(scene.particles, scene.domain, 2e-4, true);
  std::vector<std::array<std::size_t, 3>> pairs;
  list.for_each_pair([&](std::size_t i, std::size_t j, std::uint32_t k) {
    pairs.push_back({i, j, k});
  });
  ASSERT_EQ(pairs.size(), list.pair_count());
  ASSERT_GT(pairs.size(), 1000u);
  ASSERT_EQ(list.row_count(), scene.particles.size());

  // Rows split as the kernel splits them (odd sizes, so blocks straddle rows and row ranges).
  constexpr std::uint32_t kBlock = 7;
  std::vector<std::array<std::size_t, 3>> prepared, evaluated;
  std::size_t block_start = 0;
  for (std::size_t first = 0; first < list.row_count(); first += 13) {
    const std::size_t last = std::min(list.row_count(), first + 13);
    list.for_each_pair_block<kBlock>(
        first, last,
        [&](std::uint32_t s, std::size_t i, std::size_t j, std::uint32_t k) {
          EXPECT_EQ(s, prepared.size() - evaluated.size());  // a block's pairs, all prepared first
          EXPECT_LT(s, kBlock);
          EXPECT_GE(i, first);
          EXPECT_LT(i, last);
          prepared.push_back({i, j, k});
        },
        [&](std::uint32_t s, std::size_t i, std::size_t j, std::uint32_t k) {
          if (s == 0) block_start = evaluated.size();
          EXPECT_EQ(evaluated.size(), block_start + s);
          EXPECT_EQ(prepared[block_start + s], (std::array<std::size_t, 3>{i, j, k}));
          evaluated.push_back({i, j, k});
        });
    ASSERT_EQ(prepared.size(), evaluated.size());
  }
  EXPECT_EQ(prepared, pairs);
  EXPECT_EQ(evaluated, pairs);

  std::vector<int> seen(pairs.size(), 0);
  for (std::size_t m = 0; m < list.row_count(); ++m) {
    std::vector<std::uint32_t> own, other;
    bool other_begun = false;
    list.for_each_pair_of(
        m,
        [&](std::uint32_t k) {
          EXPECT_FALSE(other_begun);  // the own row comes first
          own.push_back(k);
        },
        [&](std::uint32_t k) {
          other_begun = true;
          other.push_back(k);
        });
    // Each pair is seen from its smaller id, and each particle meets its partners in id order
    // (own row, then the others): sums over them do not depend on the storage order.
    const auto& id = scene.particles.id;
    std::vector<std::int64_t> own_partners, other_partners;
    for (const std::uint32_t k : own) {
      EXPECT_EQ(pairs[k][0], m);
      EXPECT_LT(id[m], id[pairs[k][1]]);
      own_partners.push_back(id[pairs[k][1]]);
      ++seen[k];
    }
    for (const std::uint32_t k : other) {
      EXPECT_EQ(pairs[k][1], m);
      EXPECT_LT(id[pairs[k][0]], id[m]);
      other_partners.push_back(id[pairs[k][0]]);
      ++seen[k];
    }
    EXPECT_TRUE(std::is_sorted(own_partners.begin(), own_partners.end()));
    EXPECT_TRUE(std::is_sorted(other_partners.begin(), other_partners.end()));
  }
  for (const int count : seen) EXPECT_EQ(count, 2);  // once from each member
}

TEST(NeighborList, ShortPeriodicAxisOfAWideDomainKeepsThreeCells) {
  // Issue 12: a periodic y of 0.5 mm holds five cells of 90 um, but the memory cap on a wide,
  // sparsely filled domain widened all cells alike until y had one, and the build was refused.
  Case c = testing::soft_case(0.0);
  c.domain = Domain{};
  c.domain->min = Eigen::Vector3d::Zero();
  c.domain->max = Eigen::Vector3d(0.05, 0.0005, 0.05);
  c.domain->periodic = {false, true, false};
  const double r = 40e-6;
  // A pair touching across the periodic face, a pair inside, and a spread of loners.
  const std::vector<Eigen::Vector3d> centres = {{0.01, 0.00005, 0.01},  {0.01, 0.00047, 0.01},
                                                {0.03, 0.00025, 0.02},  {0.03, 0.00033, 0.02},
                                                {0.045, 0.0001, 0.001}, {0.002, 0.0004, 0.049},
                                                {0.025, 0.00049, 0.03}, {0.025, 0.00001, 0.03005}};
  for (const Eigen::Vector3d& x : centres) {
    ParticleSpec p;
    p.radius = r;
    p.position = x;
    c.particles.push_back(p);
  }
  Scene scene = build_scene(c);
  const double skin = 10e-6;
  NeighborList list;
  ASSERT_NO_THROW(list.build(scene.particles, scene.domain, skin, false));
  const PairSet expected = oracle(scene.particles, scene.domain, skin);
  EXPECT_EQ(expected.size(), 3u) << "two pairs across the face and one inside";
  EXPECT_EQ(listed_contacts(scene.particles, list, skin, scene.domain), expected);
}

/// Spheres of radius @p r on a simple cubic lattice of @p nx x @p ny x @p nz sites, spacing 2.2 r,
/// filling a domain of that size, inserted in a shuffled order; @p periodic as given.
Scene shuffled_bed(int nx, int ny, int nz, double r, std::array<bool, 3> periodic) {
  Case c = testing::soft_case(0.0);
  const double spacing = 2.2 * r;
  c.domain = Domain{};
  c.domain->min = Eigen::Vector3d::Zero();
  c.domain->max = spacing * Eigen::Vector3d(nx, ny, nz);
  c.domain->periodic = periodic;
  std::vector<Eigen::Vector3d> sites;
  for (int iz = 0; iz < nz; ++iz) {
    for (int iy = 0; iy < ny; ++iy) {
      for (int ix = 0; ix < nx; ++ix) sites.push_back(spacing * Eigen::Vector3d(ix, iy, iz));
    }
  }
  std::mt19937 random(7);
  std::shuffle(sites.begin(), sites.end(), random);
  for (const Eigen::Vector3d& site : sites) {
    ParticleSpec p;
    p.radius = r;
    p.position = site + Eigen::Vector3d::Constant(0.5 * spacing);
    c.particles.push_back(p);
  }
  return build_scene(c);
}

/// How far the first half of the particles (by index) reaches past the start of the second half
/// along @p axis: below a cell or two when the halves are slabs across that axis.
double halves_overlap(const Particles& p, int axis) {
  const StaggeredVector<double>& coord = axis == 0 ? p.x : (axis == 1 ? p.y : p.z);
  const std::size_t half = p.size() / 2;
  const double first_end = *std::max_element(coord.begin(), coord.begin() + half);
  const double second_start = *std::min_element(coord.begin() + half, coord.end());
  return first_end - second_start;
}

// Threads own contiguous ranges of the particles, which the reordering sorts by cell: the axis
// that varies slowest is the one across which the threads' ranges meet, and it must be the one
// with the smallest cut (the threads trade the data of the particles on the cut every step).
TEST(NeighborList, ReorderingRunsAlongTheSmallestCut) {
  const double r = 50e-6;
  const double skin = 10e-6;
  // A cell holds one site (cell size 2 r + skin = 2.2 r), so two cells are 4.4 r.
  const double two_cells = 4.4 * r;
  {
    // A long, shallow bed: cut across x 8 x 4 sites, across y 48 x 4, across z 48 x 8.
    Scene scene = shuffled_bed(48, 8, 4, r, {false, false, false});
    NeighborList list;
    list.build(scene.particles, scene.domain, skin, true);
    EXPECT_LT(halves_overlap(scene.particles, 0), two_cells);
    EXPECT_GT(halves_overlap(scene.particles, 2), 0.0) << "z no longer the slowest axis";
  }
  {
    // Periodic in x and filled: cut across x twice (at the middle and where x wraps), 2 x 16 x 4
    // sites, more than across y, 24 x 4. Counting the x cut once would pick x.
    Scene scene = shuffled_bed(24, 16, 4, r, {true, false, false});
    NeighborList list;
    list.build(scene.particles, scene.domain, skin, true);
    EXPECT_LT(halves_overlap(scene.particles, 1), two_cells);
    EXPECT_GT(halves_overlap(scene.particles, 0), two_cells);
    // And the list is still the oracle's.
    EXPECT_EQ(listed_contacts(scene.particles, list, skin, scene.domain),
              oracle(scene.particles, scene.domain, skin));
  }
  // A cube keeps z slowest.
  Scene scene = shuffled_bed(10, 10, 10, r, {false, false, false});
  NeighborList list;
  list.build(scene.particles, scene.domain, skin, true);
  EXPECT_LT(halves_overlap(scene.particles, 2), two_cells);
}

TEST(NeighborList, RefusesPeriodicAxisShorterThanThreeCells) {
  Case c = testing::soft_case(0.0);
  testing::add_random_gas(c, 3, 0.4e-3, 0.5e-3, 0.002, 1.0, 3);
  c.domain->periodic = {true, false, false};
  Scene scene = build_scene(c);
  EXPECT_THROW(Stepper{scene}, std::runtime_error);
}

}  // namespace
}  // namespace bondem
