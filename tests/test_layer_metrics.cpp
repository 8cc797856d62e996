// Powder-spreading metrics: bonded clusters, size quantiles, and layer solid fraction, surface
// height and coverage, against closed forms and brute-force references on hand-built states.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

#include "solver/analysis/layer_metrics.hpp"

namespace bondem {
namespace {

using PairList = std::vector<std::pair<std::uint32_t, std::uint32_t>>;

constexpr double kPi = std::numbers::pi;

double sphere_volume(double r) {
  return 4.0 / 3.0 * kPi * r * r * r;
}

/// Volume of the cap of height @p h cut from a sphere of radius @p r.
double cap_volume(double r, double h) {
  return kPi * h * h * (3.0 * r - h) / 3.0;
}

void add(Particles& p, std::int64_t id, double r, double x, double y, double z) {
  const double pos[3] = {x, y, z};
  const double vel[3] = {0.0, 0.0, 0.0};
  p.add(id, 0, r, 1.0, pos, vel);
}

Box make_box(double x0, double y0, double z0, double x1, double y1, double z1) {
  return Box{Eigen::Vector3d(x0, y0, z0), Eigen::Vector3d(x1, y1, z1)};
}

/// Uniform double in [lo, hi) from the top 53 bits, the same on every standard library.
double uniform(std::mt19937_64& g, double lo, double hi) {
  return lo + (hi - lo) * static_cast<double>(g() >> 11) * 0x1p-53;
}

/// A fixed shuffle of 0..n-1.
std::vector<std::uint32_t> shuffled(std::size_t n, std::uint64_t seed) {
  std::vector<std::uint32_t> order(n);
  for (std::size_t k = 0; k < n; ++k) order[k] = static_cast<std::uint32_t>(k);
  std::mt19937_64 g(seed);
  for (std::size_t k = n; k > 1; --k) std::swap(order[k - 1], order[g() % k]);
  return order;
}

/// @p p permuted by @p order, with @p pairs remapped to the new indices.
std::pair<Particles, PairList> permuted(const Particles& p, const PairList& pairs,
                                        const std::vector<std::uint32_t>& order) {
  Particles q = p;
  q.permute(order);
  std::vector<std::uint32_t> new_index(order.size());
  for (std::size_t k = 0; k < order.size(); ++k)
    new_index[order[k]] = static_cast<std::uint32_t>(k);
  PairList remapped;
  for (const auto& [a, b] : pairs) remapped.emplace_back(new_index[a], new_index[b]);
  return {q, remapped};
}

// ---------------------------------------------------------------------------------------------
// Clusters

/// Index: 0   1  2  3   4   5   6
/// id:    40  5  1  9   22  17  33
/// chain 1-2-3 (ids 5, 1, 9; smallest 1), pair 4-5 (ids 22, 17; smallest 17), singletons 6 (33)
/// and 0 (40): labels 0 (chain), 1 (pair), 2 (index 6), 3 (index 0).
Particles seven_particles() {
  Particles p;
  const std::int64_t ids[7] = {40, 5, 1, 9, 22, 17, 33};
  for (std::size_t k = 0; k < 7; ++k) {
    add(p, ids[k], 1e-5 * (1.0 + 0.1 * static_cast<double>(k)), static_cast<double>(k), 0, 0);
  }
  return p;
}
const PairList kSevenBonds = {{1, 2}, {3, 2}, {5, 4}};

TEST(Clusters, ChainPairAndSingletonsLabelledBySmallestId) {
  const Particles p = seven_particles();
  const ClusterReport c = find_clusters(p, kSevenBonds);
  EXPECT_EQ(c.sizes, (std::vector<std::size_t>{3, 2, 1, 1}));
  EXPECT_EQ(c.cluster_of, (std::vector<std::int64_t>{3, 0, 0, 0, 1, 1, 2}));
  ASSERT_EQ(c.volume_equivalent_diameters.size(), 4u);
  const auto r3 = [&p](std::size_t i) { return p.radius[i] * p.radius[i] * p.radius[i]; };
  EXPECT_NEAR(c.volume_equivalent_diameters[0], 2.0 * std::cbrt(r3(1) + r3(2) + r3(3)), 1e-18);
  EXPECT_NEAR(c.volume_equivalent_diameters[1], 2.0 * std::cbrt(r3(4) + r3(5)), 1e-18);
  EXPECT_NEAR(c.volume_equivalent_diameters[2], 2.0 * p.radius[6], 1e-18);
  EXPECT_NEAR(c.volume_equivalent_diameters[3], 2.0 * p.radius[0], 1e-18);
}

TEST(Clusters, SameForAnyParticleOrder) {
  const Particles p = seven_particles();
  const ClusterReport a = find_clusters(p, kSevenBonds);
  for (const std::uint64_t seed : {1u, 2u, 3u}) {
    const std::vector<std::uint32_t> order = shuffled(p.size(), seed);
    const auto [q, pairs] = permuted(p, kSevenBonds, order);
    const ClusterReport b = find_clusters(q, pairs);
    EXPECT_EQ(b.sizes, a.sizes);
    EXPECT_EQ(b.volume_equivalent_diameters, a.volume_equivalent_diameters);  // bit-identical
    for (std::size_t k = 0; k < order.size(); ++k) {
      EXPECT_EQ(b.cluster_of[k], a.cluster_of[order[k]]);
    }
  }
}

TEST(Clusters, EightEqualSpheresHaveTwiceTheDiameter) {
  // A 2x2x2 cube bonded along its 12 edges: six 4-cycles.
  const double r = 25e-6;
  Particles p;
  for (int k = 0; k < 8; ++k)
    add(p, 100 - k, r, 2 * r * (k & 1), 2 * r * (k >> 1 & 1), 2 * r * (k >> 2));
  PairList bonds;
  for (std::uint32_t a = 0; a < 8; ++a) {
    for (std::uint32_t bit : {1u, 2u, 4u}) {
      if ((a & bit) == 0) bonds.emplace_back(a, a | bit);
    }
  }
  ASSERT_EQ(bonds.size(), 12u);
  const ClusterReport c = find_clusters(p, bonds);
  ASSERT_EQ(c.sizes, (std::vector<std::size_t>{8}));
  EXPECT_NEAR(c.volume_equivalent_diameters[0], 2.0 * r * 2.0, 1e-12 * r);
  EXPECT_EQ(c.cluster_of, std::vector<std::int64_t>(8, 0));
}

TEST(Clusters, CyclesRepeatsAndSelfPairs) {
  Particles p;
  for (int k = 0; k < 5; ++k) add(p, k, 1e-5, k, 0, 0);
  // Triangle 0-1-2 given twice in both directions, a self pair on 3, 4 alone.
  const PairList bonds = {{0, 1}, {1, 2}, {2, 0}, {1, 0}, {0, 2}, {3, 3}};
  const ClusterReport c = find_clusters(p, bonds);
  EXPECT_EQ(c.sizes, (std::vector<std::size_t>{3, 1, 1}));
  EXPECT_EQ(c.cluster_of, (std::vector<std::int64_t>{0, 0, 0, 1, 2}));
}

TEST(Clusters, EmptyAndOutOfRange) {
  const Particles none;
  const ClusterReport c = find_clusters(none, {});
  EXPECT_TRUE(c.cluster_of.empty());
  EXPECT_TRUE(c.sizes.empty());
  EXPECT_THROW(find_clusters(seven_particles(), {{0, 7}}), std::out_of_range);
}

// ---------------------------------------------------------------------------------------------
// Size quantiles

TEST(SizeQuantiles, InterpolatesBetweenOrderStatistics) {
  // 1..10 in any order: positions q (n - 1) = 0.9, 4.5, 8.1 between sorted values.
  const SizeQuantiles q = size_quantiles({7, 3, 10, 1, 5, 9, 2, 8, 4, 6});
  EXPECT_EQ(q.count, 10u);
  EXPECT_NEAR(q.d10, 1.9, 1e-12);
  EXPECT_NEAR(q.d50, 5.5, 1e-12);
  EXPECT_NEAR(q.d90, 9.1, 1e-12);
}

TEST(SizeQuantiles, SmallSamples) {
  const SizeQuantiles none = size_quantiles({});
  EXPECT_EQ(none.count, 0u);
  EXPECT_EQ(none.d50, 0.0);
  const SizeQuantiles one = size_quantiles({4e-5});
  EXPECT_EQ(one.count, 1u);
  EXPECT_EQ(one.d10, 4e-5);
  EXPECT_EQ(one.d90, 4e-5);
  const SizeQuantiles two = size_quantiles({3.0, 1.0});
  EXPECT_NEAR(two.d10, 1.2, 1e-12);
  EXPECT_NEAR(two.d50, 2.0, 1e-12);
  EXPECT_NEAR(two.d90, 2.8, 1e-12);
  EXPECT_THROW(size_quantiles({1.0, std::nan("")}), std::invalid_argument);
}

TEST(SizeQuantiles, OfClusterDiameters) {
  const ClusterReport c = find_clusters(seven_particles(), kSevenBonds);
  const SizeQuantiles q = size_quantiles(c.volume_equivalent_diameters);
  EXPECT_EQ(q.count, 4u);
  std::vector<double> d = c.volume_equivalent_diameters;
  std::sort(d.begin(), d.end());
  EXPECT_NEAR(q.d50, 0.5 * (d[1] + d[2]), 1e-18);
}

// ---------------------------------------------------------------------------------------------
// Layer metrics

/// A 1 mm x 1 mm footprint, substrate at z = 0, layer 0.5 mm.
LayerRegion millimetre_region() {
  LayerRegion region;
  region.x_min = 0.0;
  region.x_max = 1e-3;
  region.y_min = 0.0;
  region.y_max = 1e-3;
  region.substrate_z = 0.0;
  region.layer_height = 0.5e-3;
  return region;
}

double box_volume(const LayerRegion& region) {
  return (region.x_max - region.x_min) * (region.y_max - region.y_min) * region.layer_height;
}

TEST(LayerMetrics, SphereInsideGivesSphereVolumeOverBoxVolume) {
  const LayerRegion region = millimetre_region();
  const double r = 0.1e-3;
  Particles p;
  add(p, 1, r, 0.5e-3, 0.4e-3, 0.25e-3);
  const LayerMetrics m = measure_layer(p, region);
  EXPECT_NEAR(m.solid_fraction, sphere_volume(r) / box_volume(region),
              1e-9 * sphere_volume(r) / box_volume(region));
  EXPECT_EQ(m.particles, 1u);
}

TEST(LayerMetrics, SphereHalvedBySubstrate) {
  const LayerRegion region = millimetre_region();
  const double r = 0.1e-3;
  Particles p;
  add(p, 1, r, 0.5e-3, 0.5e-3, region.substrate_z);
  const double expected = 0.5 * sphere_volume(r) / box_volume(region);
  EXPECT_NEAR(measure_layer(p, region).solid_fraction, expected, 1e-12 * expected);
}

TEST(LayerMetrics, SphereCutByXFaceGivesCap) {
  LayerRegion region = millimetre_region();
  region.bins = 1;
  const double r = 0.1e-3;
  const double inside = 0.3 * r;  // centre 0.3 r inside the x_min face: a cap of 0.7 r is cut off
  Particles p;
  add(p, 1, r, region.x_min + inside, 0.5e-3, 0.25e-3);
  const LayerMetrics m = measure_layer(p, region);
  const double expected = (sphere_volume(r) - cap_volume(r, r - inside)) / box_volume(region);
  EXPECT_NEAR(m.solid_fraction, expected, 1e-12 * expected);
  EXPECT_NEAR(m.bin_solid_fraction[0], expected, 1e-12 * expected);
}

TEST(LayerMetrics, ClippedVolumeMatchesClosedFormsWhenCutOnSeveralAxes) {
  // These cuts go through the quadrature path (planes of two or three axes cross the sphere).
  const double r = 2.0;
  const double v = sphere_volume(r);
  const double a = 0.6;  // x face at distance a from the centre
  const double big = 10.0;
  // Half of the cap region x >= a, halved by the plane z = 0 through the centre.
  EXPECT_NEAR(sphere_box_volume(0, 0, 0, r, make_box(a, -big, 0, big, big, big)),
              0.5 * cap_volume(r, r - a), 1e-12 * v);
  // One eighth: three faces through the centre.
  EXPECT_NEAR(sphere_box_volume(1, 2, 3, r, make_box(1, 2, 3, big, big, big)), v / 8.0, 1e-12 * v);
  // The cap x >= a split by y = b in two parts that each need the quadrature.
  for (const double b : {-1.7, -0.4, 0.0, 0.9, 1.99}) {
    const double lower = sphere_box_volume(0, 0, 0, r, make_box(a, -big, -big, big, b, big));
    const double upper = sphere_box_volume(0, 0, 0, r, make_box(a, b, -big, big, big, big));
    EXPECT_NEAR(lower + upper, cap_volume(r, r - a), 1e-12 * v) << "b = " << b;
  }
  // A partition of space into 4 x 4 x 4 boxes at irregular planes: the pieces add up to the
  // sphere, whatever mix of edges and corners cuts each one.
  const double px[5] = {-big, -1.3, 0.2, 1.1, big};
  const double py[5] = {-big, -0.5, 0.7, 1.9, big};
  const double pz[5] = {-big, -1.95, -0.1, 1.4, big};
  double sum = 0.0;
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) {
      for (int k = 0; k < 4; ++k) {
        const double piece = sphere_box_volume(
            0, 0, 0, r, make_box(px[i], py[j], pz[k], px[i + 1], py[j + 1], pz[k + 1]));
        EXPECT_GE(piece, 0.0);
        sum += piece;
      }
    }
  }
  EXPECT_NEAR(sum, v, 1e-12 * v);
  EXPECT_EQ(sphere_box_volume(0, 0, 0, r, make_box(r, -big, -big, big, big, big)), 0.0);
}

/// A square lattice of n x n touching spheres of radius r resting on the substrate, tiling the
/// footprint exactly.
Particles monolayer(int n, double r, const LayerRegion& region) {
  Particles p;
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      add(p, j * n + i, r, region.x_min + r * (2 * i + 1), region.y_min + r * (2 * j + 1),
          region.substrate_z + r);
    }
  }
  return p;
}

LayerRegion monolayer_region(int n, double r) {
  LayerRegion region;
  region.x_min = -0.3e-3;
  region.x_max = region.x_min + 2 * r * n;
  region.y_min = 0.1e-3;
  region.y_max = region.y_min + 2 * r * n;
  region.substrate_z = 0.2e-3;
  region.layer_height = 2 * r;
  return region;
}

TEST(LayerMetrics, MonolayerSolidFractionIsPiOverSix) {
  const int n = 6;
  const double r = 20e-6;
  LayerRegion region = monolayer_region(n, r);
  region.bins = 3;  // bin edges fall between spheres
  const LayerMetrics m = measure_layer(monolayer(n, r, region), region);
  EXPECT_NEAR(m.solid_fraction, kPi / 6.0, 1e-12);
  for (const double f : m.bin_solid_fraction) EXPECT_NEAR(f, kPi / 6.0, 1e-12);
  EXPECT_EQ(m.particles, static_cast<std::size_t>(n * n));
}

TEST(LayerMetrics, MonolayerSurface) {
  const int n = 4;
  const double r = 20e-6;
  LayerRegion region = monolayer_region(n, r);
  // An odd number of columns per sphere puts a column centre directly above each sphere centre.
  const int per_sphere = 101;
  region.grid_spacing = 2 * r / per_sphere;
  const LayerMetrics m = measure_layer(monolayer(n, r, region), region);
  EXPECT_EQ(m.columns, static_cast<std::size_t>(n * n * per_sphere * per_sphere));
  EXPECT_DOUBLE_EQ(m.max_surface_height, 2 * r);  // the column above each centre
  // Continuum values for a square lattice of touching spheres: covered area pi/4; over a disc the
  // height r + sqrt(r^2 - rho^2) has mean 5r/3 and standard deviation r/sqrt(18). The grid's error
  // comes from the columns near the circles: the number of column centres inside a circle of
  // R = r/h = 50.5 columns deviates from pi R^2 by O(R^(2/3)) (Gauss's circle problem), a relative
  // O(R^(-4/3)) ~ 5e-3. Measured here: 9e-4 on empty_fraction, 7e-4 r on mean and roughness.
  EXPECT_NEAR(m.empty_fraction, 1.0 - kPi / 4.0, 3e-3);
  EXPECT_NEAR(m.mean_surface_height, 5.0 * r / 3.0, 3e-3 * r);
  EXPECT_NEAR(m.roughness, r / std::sqrt(18.0), 3e-3 * r);
}

/// Brute force: every column against every particle, same definitions as measure_layer.
struct SurfaceReference {
  double mean = 0, stddev = 0, empty = 1;
};
SurfaceReference reference_surface(const Particles& p, const LayerRegion& region, double spacing) {
  const auto nx = static_cast<std::size_t>(std::round((region.x_max - region.x_min) / spacing));
  const auto ny = static_cast<std::size_t>(std::round((region.y_max - region.y_min) / spacing));
  std::vector<double> heights;
  for (std::size_t j = 0; j < ny; ++j) {
    for (std::size_t i = 0; i < nx; ++i) {
      const double xc = region.x_min + (static_cast<double>(i) + 0.5) *
                                           (region.x_max - region.x_min) / static_cast<double>(nx);
      const double yc = region.y_min + (static_cast<double>(j) + 0.5) *
                                           (region.y_max - region.y_min) / static_cast<double>(ny);
      double top = 0.0;
      for (std::size_t k = 0; k < p.size(); ++k) {
        if (p.z[k] > region.substrate_z + 3 * region.layer_height) continue;
        const double rest = p.radius[k] * p.radius[k] - (xc - p.x[k]) * (xc - p.x[k]) -
                            (yc - p.y[k]) * (yc - p.y[k]);
        if (rest >= 0.0) top = std::max(top, p.z[k] + std::sqrt(rest) - region.substrate_z);
      }
      if (top > 0.0) heights.push_back(top);
    }
  }
  SurfaceReference ref;
  ref.empty = 1.0 - static_cast<double>(heights.size()) / static_cast<double>(nx * ny);
  if (heights.empty()) return ref;
  for (const double h : heights) ref.mean += h / static_cast<double>(heights.size());
  for (const double h : heights) {
    ref.stddev += (h - ref.mean) * (h - ref.mean) / static_cast<double>(heights.size());
  }
  ref.stddev = std::sqrt(ref.stddev);
  return ref;
}

/// A loose random layer: polydisperse spheres (radii 10-40 um) scattered over and around the
/// footprint, some outside it, some below-centre, a few high above (the heap).
Particles random_layer(std::size_t n, const LayerRegion& region, std::uint64_t seed) {
  std::mt19937_64 g(seed);
  Particles p;
  for (std::size_t k = 0; k < n; ++k) {
    const double r = uniform(g, 10e-6, 40e-6);
    const double x = uniform(g, region.x_min - 0.1e-3, region.x_max + 0.1e-3);
    const double y = uniform(g, region.y_min - 0.1e-3, region.y_max + 0.1e-3);
    const double z = region.substrate_z + uniform(g, -0.5 * r, 4.0 * region.layer_height);
    add(p, static_cast<std::int64_t>(1000 + 7 * k), r, x, y, z);
  }
  return p;
}

LayerRegion random_region() {
  LayerRegion region = millimetre_region();
  region.layer_height = 80e-6;
  region.bins = 7;
  return region;
}

TEST(LayerMetrics, SurfaceMatchesBruteForce) {
  LayerRegion region = random_region();
  region.grid_spacing = 5e-6;
  const Particles p = random_layer(600, region, 11);
  const LayerMetrics m = measure_layer(p, region);
  const SurfaceReference ref = reference_surface(p, region, region.grid_spacing);
  EXPECT_NEAR(m.mean_surface_height, ref.mean, 1e-12 * ref.mean);
  EXPECT_NEAR(m.roughness, ref.stddev, 1e-10 * ref.stddev);
  EXPECT_NEAR(m.empty_fraction, ref.empty, 1e-15);
  EXPECT_GT(m.empty_fraction, 0.05);  // the test sees both covered and bare columns
  EXPECT_LT(m.empty_fraction, 0.95);
  // The bins tile the layer box: their mean is the whole box's solid fraction.
  double mean_bin = 0.0;
  for (const double f : m.bin_solid_fraction) mean_bin += f / region.bins;
  EXPECT_NEAR(mean_bin, m.solid_fraction, 1e-12);
}

TEST(LayerMetrics, SurfaceMatchesBruteForceOverSeveralBands) {
  // 526 x 526 columns: more than one band of rows of the height map (2^18 columns per band).
  LayerRegion region = random_region();
  region.grid_spacing = 1.9e-6;
  Particles p = random_layer(150, region, 23);
  // Straddles the boundary between the first two bands (row 498).
  add(p, 1, 30e-6, 0.5e-3, 0.946e-3, 20e-6);
  const LayerMetrics m = measure_layer(p, region);
  ASSERT_GT(m.columns, std::size_t{1} << 18);
  const SurfaceReference ref = reference_surface(p, region, region.grid_spacing);
  EXPECT_NEAR(m.mean_surface_height, ref.mean, 1e-12 * ref.mean);
  EXPECT_NEAR(m.roughness, ref.stddev, 1e-10 * ref.stddev);
  EXPECT_NEAR(m.empty_fraction, ref.empty, 1e-15);
  EXPECT_GT(m.empty_fraction, 0.05);
  EXPECT_LT(m.empty_fraction, 0.95);
}

TEST(LayerMetrics, DefaultGridIsAQuarterOfTheSmallestRadius) {
  LayerRegion region = random_region();
  const Particles p = random_layer(300, region, 5);
  const LayerMetrics m = measure_layer(p, region);
  double r_min = 1.0;
  for (std::size_t k = 0; k < p.size(); ++k) {
    if (p.z[k] <= region.substrate_z + 3 * region.layer_height && p.x[k] + p.radius[k] > 0 &&
        p.x[k] - p.radius[k] < 1e-3 && p.y[k] + p.radius[k] > 0 && p.y[k] - p.radius[k] < 1e-3) {
      r_min = std::min(r_min, p.radius[k]);
    }
  }
  const auto side = static_cast<std::size_t>(std::round(1e-3 / (0.25 * r_min)));
  EXPECT_EQ(m.columns, side * side);
  const SurfaceReference ref = reference_surface(p, region, 0.25 * r_min);
  EXPECT_NEAR(m.mean_surface_height, ref.mean, 1e-12 * ref.mean);
  EXPECT_NEAR(m.empty_fraction, ref.empty, 1e-15);
}

TEST(LayerMetrics, SameForAnyParticleOrder) {
  const LayerRegion region = random_region();
  const Particles p = random_layer(800, region, 3);
  const LayerMetrics a = measure_layer(p, region);
  Particles q = p;
  q.permute(shuffled(p.size(), 99));
  const LayerMetrics b = measure_layer(q, region);
  // Bit-identical, not merely close.
  EXPECT_EQ(a.bin_solid_fraction, b.bin_solid_fraction);
  EXPECT_EQ(a.solid_fraction, b.solid_fraction);
  EXPECT_EQ(a.mean_surface_height, b.mean_surface_height);
  EXPECT_EQ(a.roughness, b.roughness);
  EXPECT_EQ(a.empty_fraction, b.empty_fraction);
  EXPECT_EQ(a.particles, b.particles);
}

TEST(LayerMetrics, EmptyRegion) {
  LayerRegion region = millimetre_region();
  for (const double spacing : {0.0, 20e-6}) {
    region.grid_spacing = spacing;
    Particles p;
    const LayerMetrics none = measure_layer(p, region);
    EXPECT_EQ(none.empty_fraction, 1.0);
    EXPECT_EQ(none.solid_fraction, 0.0);
    // Particles elsewhere: beside the footprint, and above the surface cut-off.
    add(p, 1, 50e-6, 2e-3, 0.5e-3, 0.1e-3);
    add(p, 2, 50e-6, 0.5e-3, 0.5e-3, region.substrate_z + 3.5 * region.layer_height);
    const LayerMetrics m = measure_layer(p, region);
    EXPECT_EQ(m.empty_fraction, 1.0);
    EXPECT_EQ(m.solid_fraction, 0.0);
    EXPECT_EQ(m.mean_surface_height, 0.0);
    EXPECT_EQ(m.roughness, 0.0);
    EXPECT_EQ(m.covered_columns, 0u);
    EXPECT_EQ(m.bin_solid_fraction, std::vector<double>(10, 0.0));
    EXPECT_EQ(m.particles, 1u);  // the one above the layer counts: centre over the footprint
  }
}

TEST(LayerMetrics, BinsSeeOnlyTheFirstHalf) {
  const LayerRegion region = millimetre_region();  // 10 bins of 0.1 mm
  const double r = 30e-6;
  Particles p;
  for (int k = 0; k < 5; ++k) add(p, k, r, (k + 0.5) * 0.1e-3, 0.5e-3, 0.1e-3);
  add(p, 5, r, 0.4e-3, 0.2e-3, 0.1e-3);  // halved by the edge between bins 3 and 4
  const LayerMetrics m = measure_layer(p, region);
  ASSERT_EQ(m.bin_solid_fraction.size(), 10u);
  const double slab = 0.1e-3 * 1e-3 * region.layer_height;
  for (std::size_t k = 0; k < 10; ++k) {
    EXPECT_NEAR(m.bin_x_center[k], (static_cast<double>(k) + 0.5) * 0.1e-3, 1e-15);
    const double spheres = k < 3 ? 1.0 : k < 5 ? 1.5 : 0.0;
    if (k < 5) {
      EXPECT_NEAR(m.bin_solid_fraction[k], spheres * sphere_volume(r) / slab, 1e-12);
    } else {
      EXPECT_EQ(m.bin_solid_fraction[k], 0.0);
    }
  }
  EXPECT_NEAR(m.solid_fraction, 6 * sphere_volume(r) / box_volume(region), 1e-12);
}

TEST(LayerMetrics, HeapAboveThreeLayerHeightsIsIgnoredForTheSurface) {
  LayerRegion region = millimetre_region();
  region.layer_height = 50e-6;
  region.grid_spacing = 10e-6;
  const double r = 20e-6;
  Particles p;
  // x = y = 0.505 mm is a column centre, so the column above the sphere's centre exists.
  add(p, 1, r, 0.505e-3, 0.505e-3, r);
  const LayerMetrics alone = measure_layer(p, region);
  EXPECT_DOUBLE_EQ(alone.max_surface_height, 2 * r);
  add(p, 2, r, 0.505e-3, 0.505e-3, 3 * region.layer_height + 1e-9);  // just above the cut-off
  const LayerMetrics with_heap = measure_layer(p, region);
  EXPECT_EQ(with_heap.mean_surface_height, alone.mean_surface_height);
  EXPECT_EQ(with_heap.covered_columns, alone.covered_columns);
  add(p, 3, r, 0.505e-3, 0.505e-3, 3 * region.layer_height);  // at the cut-off: counts
  EXPECT_DOUBLE_EQ(measure_layer(p, region).max_surface_height, 3 * region.layer_height + r);
}

TEST(LayerMetrics, InvalidRegionThrows) {
  const Particles p;
  LayerRegion region = millimetre_region();
  region.x_max = region.x_min;
  EXPECT_THROW(measure_layer(p, region), std::invalid_argument);
  region = millimetre_region();
  region.layer_height = 0;
  EXPECT_THROW(measure_layer(p, region), std::invalid_argument);
  region = millimetre_region();
  region.bins = 0;
  EXPECT_THROW(measure_layer(p, region), std::invalid_argument);
  region = millimetre_region();
  region.grid_spacing = -1;
  EXPECT_THROW(measure_layer(p, region), std::invalid_argument);
  region = millimetre_region();
  region.grid_spacing = 1e-12;  // 10^18 columns
  EXPECT_THROW(measure_layer(p, region), std::invalid_argument);
}

// The reader refuses a grid before the run with the count measure_layer refuses after it.
TEST(LayerMetrics, GridColumnCountMatchesTheRefusal) {
  const LayerRegion region = millimetre_region();  // 1 mm x 1 mm footprint
  EXPECT_EQ(layer_grid_columns(region, 0.1e-3), 100.0);
  EXPECT_EQ(layer_grid_columns(region, 0.3e-3), 9.0);  // round(3.33) = 3 per side
  EXPECT_EQ(layer_grid_columns(region, 10e-3), 1.0);   // at least one column per side
  EXPECT_EQ(layer_grid_columns(region, 1e-12), 1e18);  // no wrap-around
  LayerRegion fine = region;
  fine.grid_spacing = 1e-3 / 31623.0;  // 31 623^2 = 1.00001e9 columns: just over the limit
  EXPECT_GT(layer_grid_columns(fine, fine.grid_spacing), kMaxLayerColumns);
  EXPECT_THROW(measure_layer(Particles{}, fine), std::invalid_argument);
}

}  // namespace
}  // namespace bondem
