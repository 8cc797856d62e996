// Recursive coordinate bisection: subdomains of equal cost that tile the domain, whatever the
// order of the particles.
#include <gtest/gtest.h>

#include <algorithm>
#include <barrier>
#include <numeric>
#include <random>
#include <span>
#include <stdexcept>
#include <thread>
#include <vector>

#include "solver/parallel/decomposition.hpp"

namespace bondem {
namespace {

struct Cloud {
  std::vector<double> x, y, z, cost;
  std::vector<std::int64_t> id;
  void add(double px, double py, double pz, double c) {
    x.push_back(px);
    y.push_back(py);
    z.push_back(pz);
    cost.push_back(c);
    id.push_back(static_cast<std::int64_t>(id.size()));
  }
  Decomposition bisect_into(int ranks, const Box& domain, double min_width) const {
    return bisect(x, y, z, cost, id, domain, ranks, min_width);
  }
  /// Total cost per rank.
  std::vector<double> costs(const Decomposition& d) const {
    std::vector<double> per_rank(static_cast<std::size_t>(d.ranks()), 0.0);
    for (std::size_t i = 0; i < x.size(); ++i) {
      per_rank[static_cast<std::size_t>(d.owner(x[i], y[i], z[i]))] += cost[i];
    }
    return per_rank;
  }
};

const Box kUnit{Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones()};

/// A heap: a dense cone of particles on a sparse floor layer, costs 1 + contacts (dense: 7).
Cloud heap(unsigned seed) {
  Cloud cloud;
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int k = 0; k < 6000; ++k) {
    const double px = u(random), py = u(random), pz = u(random);
    const double r = std::hypot(px - 0.3, py - 0.3);
    if (pz < 0.8 * (1.0 - 2.5 * r))
      cloud.add(px, py, pz, 7.0);  // inside the cone: dense
    else if (pz < 0.1)
      cloud.add(px, py, pz, 1.0);  // a sparse layer elsewhere
  }
  return cloud;
}

TEST(Bisection, SubdomainsTileTheDomainAndOwnTheirPoints) {
  const Cloud cloud = heap(1);
  for (int ranks = 1; ranks <= 7; ++ranks) {
    const Decomposition d = cloud.bisect_into(ranks, kUnit, 0.02);
    ASSERT_EQ(d.ranks(), ranks);
    double volume = 0.0;
    for (int r = 0; r < ranks; ++r) {
      const Box b = d.box(r, kUnit);
      const Eigen::Vector3d side = b.max - b.min;
      volume += side.prod();
      EXPECT_GE(side.minCoeff(), 0.02 * (1.0 - 1e-12)) << ranks << " ranks, rank " << r;
    }
    EXPECT_NEAR(volume, 1.0, 1e-12) << ranks << " ranks";
    // Every particle, and every point of a grid, lies in the box of its owner (half-open
    // boxes: a point on a cut belongs to the high side).
    std::mt19937_64 random(ranks);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int k = 0; k < 2000; ++k) {
      const Eigen::Vector3d p(u(random), u(random), u(random));
      const Box b = d.box(d.owner(p.x(), p.y(), p.z()), kUnit);
      EXPECT_TRUE((p.array() >= b.min.array()).all() && (p.array() < b.max.array()).all());
    }
  }
}

TEST(Bisection, CostIsBalancedOnAHeap) {
  // Equal particle counts would leave the ranks holding the cone with most of the contacts. A
  // cut falls between two particles, so a side misses its share by at most the cost of the
  // particles at the cut: a few times 7 against shares of thousands.
  const Cloud cloud = heap(2);
  const double total = std::accumulate(cloud.cost.begin(), cloud.cost.end(), 0.0);
  for (int ranks : {2, 3, 4, 5, 8}) {
    const std::vector<double> per_rank = cloud.costs(cloud.bisect_into(ranks, kUnit, 0.02));
    const double mean = total / ranks;
    for (const double c : per_rank) EXPECT_NEAR(c, mean, 0.01 * mean) << ranks << " ranks";
    // Cuts by particle count alone leave a rank far from its share of the cost (measured: the
    // busiest rank 1.19-1.40 times the mean).
    Cloud counted = cloud;
    std::fill(counted.cost.begin(), counted.cost.end(), 1.0);
    const std::vector<double> by_count = cloud.costs(counted.bisect_into(ranks, kUnit, 0.02));
    const double worst = *std::max_element(by_count.begin(), by_count.end());
    EXPECT_GT(worst, 1.15 * mean) << ranks << " ranks: the heap does not test the weighting";
  }
}

TEST(Bisection, TheSameCutsWhateverTheOrderOfTheParticles) {
  Cloud cloud = heap(3);
  // Ties on a coordinate (a lattice plane) are split by id, not by the order given.
  for (int k = 0; k < 200; ++k) cloud.add(0.5, 0.005 * k, 0.05, 1.0);
  const Decomposition reference = cloud.bisect_into(6, kUnit, 0.02);
  std::vector<std::size_t> order(cloud.x.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::shuffle(order.begin(), order.end(), std::mt19937_64(4));
  Cloud shuffled;
  for (const std::size_t i : order) {
    shuffled.add(cloud.x[i], cloud.y[i], cloud.z[i], cloud.cost[i]);
    shuffled.id.back() = cloud.id[i];
  }
  const Decomposition again = shuffled.bisect_into(6, kUnit, 0.02);
  ASSERT_EQ(again.cuts().size(), reference.cuts().size());
  for (std::size_t k = 0; k < reference.cuts().size(); ++k) {
    EXPECT_EQ(again.cuts()[k].axis, reference.cuts()[k].axis);
    EXPECT_EQ(again.cuts()[k].position, reference.cuts()[k].position);
    EXPECT_EQ(again.cuts()[k].rank, reference.cuts()[k].rank);
  }
}

/// bisect_spread() of @p cloud dealt at random over @p processes processes, each played by a
/// thread; their reductions combine the processes' values in process order. Returns every
/// process's cuts.
std::vector<Decomposition> spread_bisection(const Cloud& cloud, int processes, int ranks,
                                            double min_width) {
  const auto count = static_cast<std::size_t>(processes);
  std::vector<Cloud> parts(count);
  std::mt19937_64 deal(17);
  for (std::size_t i = 0; i < cloud.x.size(); ++i) {
    parts[deal() % count].add(cloud.x[i], cloud.y[i], cloud.z[i], cloud.cost[i]);
  }
  std::barrier sync(processes);
  std::vector<std::vector<double>> posted(count);
  const auto reduction = [&](std::size_t process, auto combine) {
    return [&, process, combine](std::span<double> values) {
      posted[process].assign(values.begin(), values.end());
      sync.arrive_and_wait();
      for (std::size_t v = 0; v < values.size(); ++v) {
        double result = posted[0][v];
        for (std::size_t q = 1; q < count; ++q) result = combine(result, posted[q][v]);
        values[v] = result;
      }
      sync.arrive_and_wait();  // all have read before anyone posts again
    };
  };
  std::vector<Decomposition> cuts(count);
  std::vector<std::thread> threads;
  for (std::size_t q = 0; q < count; ++q) {
    threads.emplace_back([&, q] {
      const SpreadReductions across{
          reduction(q, [](double a, double b) { return a + b; }),
          reduction(q, [](double a, double b) { return std::max(a, b); })};
      const Cloud& part = parts[q];
      cuts[q] = bisect_spread(part.x, part.y, part.z, part.cost, kUnit, ranks, min_width, across);
    });
  }
  for (std::thread& thread : threads) thread.join();
  return cuts;
}

TEST(Bisection, SpreadOverProcessesGivesTheCutsOfOneProcess) {
  // A rebalancing run finds its cuts without any process holding every particle: from sums and
  // extremes across the processes. They must be bisect()'s cuts of all the particles, to the bit,
  // on every process: with ties on lattice planes, costs 1 and 7, and cuts the minimum width
  // moves.
  Cloud cloud = heap(5);
  for (int k = 0; k < 300; ++k) cloud.add(0.5, 0.003 * k, 0.05, 1.0);
  for (int k = 0; k < 300; ++k) cloud.add(0.02 * (k % 50), 0.25, 0.02 * (k / 50), 7.0);
  // Three in a row halve at a tie (1 or 2 of the 3 below): bisect() takes the lower split.
  Cloud row;
  for (const double px : {0.1, 0.2, 0.3}) row.add(px, 0.5, 0.5, 1.0);
  for (const int processes : {1, 3}) {
    for (const Decomposition& spread : spread_bisection(row, processes, 2, 0.02)) {
      EXPECT_EQ(spread.cuts().front().position,
                row.bisect_into(2, kUnit, 0.02).cuts().front().position);
    }
    for (const int ranks : {2, 3, 5, 6}) {
      for (const double min_width : {0.02, 0.3}) {
        if (ranks > 2 && min_width > 0.1) continue;  // too many ranks for that width
        const Decomposition reference = cloud.bisect_into(ranks, kUnit, min_width);
        for (const Decomposition& spread : spread_bisection(cloud, processes, ranks, min_width)) {
          ASSERT_EQ(spread.cuts().size(), reference.cuts().size());
          for (std::size_t k = 0; k < reference.cuts().size(); ++k) {
            const BisectionCut& a = reference.cuts()[k];
            const BisectionCut& b = spread.cuts()[k];
            EXPECT_TRUE(a.axis == b.axis && a.position == b.position && a.low == b.low &&
                        a.high == b.high && a.rank == b.rank)
                << processes << " processes, " << ranks << " ranks, width " << min_width << ": cut "
                << k << " at " << b.position << " on axis " << b.axis << ", one process "
                << a.position << " on axis " << a.axis;
          }
        }
      }
    }
  }
}

TEST(Bisection, MinimumWidthBoundsTheCutsAndTooManyRanksAreRefused) {
  // All the cost in a thin sheet at x = 0.5: the cost would put the cuts within it, the
  // minimum width keeps the subdomains 0.2 wide.
  Cloud sheet;
  for (int k = 0; k < 1000; ++k) sheet.add(0.5 + 1e-6 * k, 0.5, 0.5, 1.0);
  const Box slab{Eigen::Vector3d::Zero(), Eigen::Vector3d(1.0, 0.1, 0.1)};
  const Decomposition d = sheet.bisect_into(4, slab, 0.2);
  for (int r = 0; r < 4; ++r) {
    const Box b = d.box(r, slab);
    EXPECT_GE(b.max.x() - b.min.x(), 0.2 * (1.0 - 1e-12));
  }
  EXPECT_THROW(sheet.bisect_into(6, slab, 0.2), std::invalid_argument);  // 6 x 0.2 > 1
  EXPECT_THROW(sheet.bisect_into(0, slab, 0.2), std::invalid_argument);
}

TEST(Bisection, SubdomainMembersAreTheOwnedAndTheHaloAcrossPeriodicFaces) {
  // Evenly spread along x: two ranks cut at x = 0.5 (y and z too short to cut).
  Cloud line;
  for (int k = 0; k < 100; ++k) line.add(0.005 + 0.01 * k, 0.05, 0.05, 1.0);
  Domain domain;
  domain.max = Eigen::Vector3d(1.0, 0.1, 0.1);
  const Decomposition d = line.bisect_into(2, Box{domain.min, domain.max}, 0.1);
  ASSERT_EQ(d.cuts()[0].axis, 0);
  ASSERT_DOUBLE_EQ(d.cuts()[0].position, 0.5);
  const auto members = [&](int rank) {
    std::vector<double> xs;
    for (const std::uint32_t i : subdomain_members(d, rank, domain, 0.03, line.x, line.y, line.z)) {
      xs.push_back(line.x[i]);
    }
    return xs;
  };
  // Closed: rank 0 holds x < 0.5 and the three particles within 0.03 above the cut.
  std::vector<double> low = members(0);
  ASSERT_EQ(low.size(), 53u);
  EXPECT_DOUBLE_EQ(low.back(), 0.525);
  // Periodic along x: also the three at the far face, within 0.03 of x = 0 through the wrap.
  domain.periodic[0] = true;
  low = members(0);
  ASSERT_EQ(low.size(), 56u);
  EXPECT_DOUBLE_EQ(low.back(), 0.995);
  EXPECT_EQ(members(1).size(), 56u);
}

}  // namespace
}  // namespace bondem
