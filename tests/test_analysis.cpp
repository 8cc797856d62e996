// Bed analysis: exact sphere-box volumes, empty or too-small regions, clusters.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <numbers>
#include <numeric>
#include <random>
#include <vector>

#include "solver/analysis/packing.hpp"

namespace bondem {
namespace {

constexpr double kRadius = 1e-3;
/// Lattice spacing: slightly below a diameter, so that lattice neighbours touch (overlap 1 %).
constexpr double kSpacing = 1.98e-3;

double sphere_volume(double r) {
  return 4.0 / 3.0 * std::numbers::pi * r * r * r;
}

/// Simple-cubic lattice of equal spheres, centres at (i, j, k) kSpacing for i < nx, j < ny,
/// k < nz.
Particles lattice(int nx, int ny, int nz) {
  Particles p;
  const double velocity[3] = {0.0, 0.0, 0.0};
  std::int64_t id = 0;
  for (int i = 0; i < nx; ++i) {
    for (int j = 0; j < ny; ++j) {
      for (int k = 0; k < nz; ++k) {
        const double position[3] = {i * kSpacing, j * kSpacing, k * kSpacing};
        p.add(id++, 0, kRadius, 1.0, position, velocity);
      }
    }
  }
  return p;
}

/// Domain around the lattice, 2 radii wider on every side.
Domain padded(int nx, int ny, int nz) {
  Domain d;
  d.min = Eigen::Vector3d::Constant(-2.0 * kRadius);
  d.max = Eigen::Vector3d((nx - 1) * kSpacing, (ny - 1) * kSpacing, (nz - 1) * kSpacing).array() +
          2.0 * kRadius;
  return d;
}

Box cube(double side) {
  return Box{Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(side)};
}

PackingReport measure(Particles& p, const Domain& domain, const Box& region) {
  NeighborList list;
  list.build(p, domain, 0.1 * kRadius, false);
  return analyse_packing(p, list, region, domain);
}

// Faces through lattice planes of centres: the spheres on a face are cut in half, on an edge in
// quarters, at a corner in eighths; the region of k^3 cells holds exactly k^3 spheres' volume,
// so the solid fraction is V_sphere / a^3 (0.5397). Counting whole spheres by centre, as before,
// gave (k + 1)^3 / k^3 times that: 1.95 times at k = 4.
TEST(BedAnalysis, LatticeRegionThroughCentresGivesTheCellFraction) {
  const int k = 4;
  Particles p = lattice(k + 1, k + 1, k + 1);
  const PackingReport r = measure(p, padded(k + 1, k + 1, k + 1), cube(k * kSpacing));
  ASSERT_TRUE(r.solid_fraction.has_value()) << r.unmeasured_reason;
  const double exact = sphere_volume(kRadius) / (kSpacing * kSpacing * kSpacing);
  // sphere_box_volume is exact to ~1e-15 of a sphere; 125 sums stay far below 1e-12.
  EXPECT_NEAR(*r.solid_fraction, exact, 1e-12 * exact);
  EXPECT_EQ(r.particles, 125u);
  // Lattice bonds 3 k (k + 1)^2 = 300, two ends each, over 125 particles.
  ASSERT_TRUE(r.mean_coordination.has_value());
  EXPECT_DOUBLE_EQ(*r.mean_coordination, 600.0 / 125.0);
}

// A sphere on a periodic face has half its volume inside and half through its image on the
// opposite face: the periodic lattice fills the domain at the same fraction.
TEST(BedAnalysis, PeriodicImagesAddTheVolumeCutOffAtTheFace) {
  const int k = 5;
  Particles p = lattice(k, k + 1, k + 1);  // x = 0 .. (k-1) a; x = k a is the image of x = 0
  Domain d = padded(k + 1, k + 1, k + 1);
  d.min.x() = 0.0;
  d.max.x() = k * kSpacing;
  d.periodic[0] = true;
  const PackingReport r = measure(p, d, cube(k * kSpacing));
  ASSERT_TRUE(r.solid_fraction.has_value()) << r.unmeasured_reason;
  const double exact = sphere_volume(kRadius) / (kSpacing * kSpacing * kSpacing);
  EXPECT_NEAR(*r.solid_fraction, exact, 1e-12 * exact);
}

// The sums run in id order: storing the particles in another order changes no bit.
TEST(BedAnalysis, ParticleOrderChangesNothing) {
  Particles p = lattice(6, 6, 6);
  // Shift one plane so that the region cuts spheres at various heights.
  for (std::size_t i = 0; i < p.size(); ++i)
    p.z[i] += 0.3 * kRadius * std::sin(7.0 * p.x[i] / kRadius);
  const Box region{Eigen::Vector3d::Constant(0.37 * kRadius),
                   Eigen::Vector3d::Constant(9.1 * kRadius)};
  const Domain d = padded(6, 6, 6);
  const PackingReport a = measure(p, d, region);
  std::vector<std::uint32_t> order(p.size());
  std::iota(order.begin(), order.end(), 0u);
  std::shuffle(order.begin(), order.end(), std::mt19937(3));
  p.permute(order);
  const PackingReport b = measure(p, d, region);
  ASSERT_TRUE(a.solid_fraction && b.solid_fraction) << a.unmeasured_reason;
  EXPECT_EQ(*a.solid_fraction, *b.solid_fraction);
  EXPECT_EQ(*a.mean_coordination, *b.mean_coordination);
}

// A bed two spheres deep is thinner than the 4-radius margins at the walls and below the top:
// the default bed region comes out inverted, and the analysis says so instead of printing 0.
TEST(BedAnalysis, ShallowBedGivesAnEmptyRegionAndNoNumber) {
  Particles p = lattice(10, 10, 2);
  const Domain d = padded(10, 10, 2);
  const Box region = bed_region(p, Box{d.min, d.max}, 4.0 * kRadius);
  EXPECT_LT(region.max.z(), region.min.z());
  const PackingReport r = measure(p, d, region);
  EXPECT_FALSE(r.solid_fraction.has_value());
  EXPECT_FALSE(r.mean_coordination.has_value());
  EXPECT_EQ(r.particles, 0u);
  EXPECT_NE(r.unmeasured_reason.find("empty along z"), std::string::npos) << r.unmeasured_reason;
}

// Regions thinner than kMinRegionDiameters mean diameters, or with fewer than
// kMinRegionParticles centres, give no number (a few spheres read anywhere from 0 to above
// random close packing).
TEST(BedAnalysis, TooSmallRegionsGiveNoNumber) {
  Particles p = lattice(10, 10, 10);
  const Domain d = padded(10, 10, 10);
  const Box thin{Eigen::Vector3d::Zero(),
                 Eigen::Vector3d(18 * kSpacing, 18 * kSpacing, 2.9 * 2.0 * kRadius)};
  const PackingReport slab = measure(p, d, thin);
  EXPECT_FALSE(slab.solid_fraction.has_value());
  EXPECT_NE(slab.unmeasured_reason.find("mean particle diameters along z, fewer than 3"),
            std::string::npos)
      << slab.unmeasured_reason;

  // Just over 3 diameters on every side (3.04 spacings), holding 3 x 3 x 3 = 27 centres.
  const Box small{Eigen::Vector3d::Constant(0.05 * kSpacing),
                  Eigen::Vector3d::Constant(3.09 * kSpacing)};
  const PackingReport few = measure(p, d, small);
  EXPECT_FALSE(few.solid_fraction.has_value());
  EXPECT_EQ(few.particles, 27u);
  EXPECT_NE(few.unmeasured_reason.find("only 27 particle centres in the region, fewer than 30"),
            std::string::npos)
      << few.unmeasured_reason;
}

}  // namespace
}  // namespace bondem
