// Particle insertion: lattice geometry, random fill validity, determinism, targets, distributions.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "solver/setup/insertion.hpp"

namespace bondem {
namespace {

double sphere_volume(double r) {
  return 4.0 / 3.0 * std::numbers::pi * r * r * r;
}

Box make_box(double x0, double y0, double z0, double x1, double y1, double z1) {
  return Box{Eigen::Vector3d(x0, y0, z0), Eigen::Vector3d(x1, y1, z1)};
}

RadiusDistribution uniform_radius(double lo, double hi) {
  RadiusDistribution d;
  d.kind = RadiusDistribution::Kind::kUniform;
  d.min = lo;
  d.max = hi;
  return d;
}

RadiusDistribution constant_radius(double r) {
  RadiusDistribution d;
  d.value = r;
  return d;
}

/// Brute-force O(N^2) check of the two properties every fill must have, against @p others too.
void expect_valid_packing(const std::vector<ParticleSpec>& p, const Box& region,
                          const std::vector<ParticleSpec>& others = {}) {
  // Relative slack for rounding of the center coordinates only.
  const double eps = 1e-12 * (region.max - region.min).maxCoeff();
  int outside = 0, overlapping = 0;
  for (const ParticleSpec& s : p) {
    for (int a = 0; a < 3; ++a) {
      if (s.position[a] - s.radius < region.min[a] - eps ||
          s.position[a] + s.radius > region.max[a] + eps) {
        ++outside;
      }
    }
  }
  for (std::size_t i = 0; i < p.size(); ++i) {
    for (std::size_t j = i + 1; j < p.size(); ++j) {
      if ((p[i].position - p[j].position).norm() < p[i].radius + p[j].radius - eps) ++overlapping;
    }
    for (const ParticleSpec& o : others) {
      if ((p[i].position - o.position).norm() < p[i].radius + o.radius - eps) ++overlapping;
    }
  }
  EXPECT_EQ(outside, 0);
  EXPECT_EQ(overlapping, 0);
}

double total_volume(const std::vector<ParticleSpec>& p) {
  double v = 0.0;
  for (const ParticleSpec& s : p) v += sphere_volume(s.radius);
  return v;
}

TEST(Insertion, LatticeCountAndPositions) {
  // Per axis: centers 0.1 + 0.25 k while center + 0.1 <= max.
  // x in [0, 1]: 0.1, 0.35, 0.6, 0.85 (1.1 + 0.1 > 1) -> 4; y in [0, 0.6]: 0.1, 0.35 -> 2;
  // z in [-0.5, 0]: -0.4, -0.15 -> 2.
  const Box region = make_box(0.0, 0.0, -0.5, 1.0, 0.6, 0.0);
  const auto p = insert_lattice(region, 0.25, 0.1, 3);
  ASSERT_EQ(p.size(), 16u);
  const double tol = 1e-15;
  EXPECT_NEAR(p[0].position.x(), 0.1, tol);
  EXPECT_NEAR(p[0].position.y(), 0.1, tol);
  EXPECT_NEAR(p[0].position.z(), -0.4, tol);
  // x fastest, then y, then z: index 4*2*k + 4*j + i.
  EXPECT_NEAR(p[3].position.x(), 0.85, tol);
  EXPECT_NEAR(p[5].position.x(), 0.35, tol);
  EXPECT_NEAR(p[5].position.y(), 0.35, tol);
  EXPECT_NEAR(p[15].position.x(), 0.85, tol);
  EXPECT_NEAR(p[15].position.y(), 0.35, tol);
  EXPECT_NEAR(p[15].position.z(), -0.15, tol);
  for (const ParticleSpec& s : p) {
    EXPECT_EQ(s.material, 3);
    EXPECT_EQ(s.radius, 0.1);
    EXPECT_EQ(s.velocity, Eigen::Vector3d::Zero());
  }
  expect_valid_packing(p, region);
}

TEST(Insertion, LatticeKeepsLayerTouchingTheWall) {
  // 5 touching spheres of radius 0.1 span exactly 1: rounding must not drop the last layer.
  const auto p = insert_lattice(make_box(0, 0, 0, 1, 1, 1), 0.2, 0.1, 0);
  EXPECT_EQ(p.size(), 125u);
  // One sphere exactly fits; spacing larger than the box still gives that one.
  EXPECT_EQ(insert_lattice(make_box(0, 0, 0, 0.2, 0.2, 0.2), 5.0, 0.1, 0).size(), 1u);
}

TEST(Insertion, LatticeRejectsBadInput) {
  const Box box = make_box(0, 0, 0, 1, 1, 1);
  EXPECT_THROW(insert_lattice(box, 0.0, 0.1, 0), std::invalid_argument);
  EXPECT_THROW(insert_lattice(box, 0.2, -0.1, 0), std::invalid_argument);
  EXPECT_THROW(insert_lattice(box, 0.2, 0.1, -1), std::invalid_argument);
  EXPECT_THROW(insert_lattice(box, 2.0, 0.6, 0), std::invalid_argument);  // does not fit
  EXPECT_THROW(insert_lattice(make_box(0, 0, 0, 1, 0, 1), 0.2, 0.1, 0), std::invalid_argument);
}

FillRequest polydisperse_request() {
  // Size ratio 5:1; 2000 spheres of mean volume 1.634e-10 m^3 in 1.2e-6 m^3: solid fraction 0.27.
  FillRequest r;
  r.region = make_box(0, 0, 0, 10e-3, 10e-3, 12e-3);
  r.material = 1;
  r.radius = uniform_radius(0.1e-3, 0.5e-3);
  r.count = 2000;
  r.seed = 42;
  r.velocity = Eigen::Vector3d(0.0, 0.0, -0.5);
  return r;
}

TEST(Insertion, RandomFillPolydisperseNoOverlapInsideRegion) {
  const FillRequest request = polydisperse_request();
  const auto p = insert_random_fill(request);
  ASSERT_EQ(p.size(), 2000u);
  double smallest = 1.0, largest = 0.0;
  for (const ParticleSpec& s : p) {
    smallest = std::min(smallest, s.radius);
    largest = std::max(largest, s.radius);
    EXPECT_EQ(s.material, 1);
    EXPECT_EQ(s.velocity, request.velocity);
  }
  EXPECT_GE(smallest, 0.1e-3);
  EXPECT_LE(largest, 0.5e-3);
  // 2000 uniform draws cover the range: both ends within 1 % of the width (miss chance ~e^-20).
  EXPECT_LT(smallest, 0.104e-3);
  EXPECT_GT(largest, 0.496e-3);
  expect_valid_packing(p, request.region);
}

TEST(Insertion, RandomFillAvoidsExistingParticles) {
  FillRequest request = polydisperse_request();
  request.count = 1000;
  // A sphere larger than any inserted one (goes to the coarse "big" lookup), one reaching into the
  // region from outside, a small one inside, and a far one that must be ignored.
  std::vector<ParticleSpec> existing(4);
  existing[0].radius = 2e-3;
  existing[0].position = Eigen::Vector3d(5e-3, 5e-3, 6e-3);
  existing[1].radius = 1e-3;
  existing[1].position = Eigen::Vector3d(-0.5e-3, 5e-3, 3e-3);
  existing[2].radius = 0.2e-3;
  existing[2].position = Eigen::Vector3d(2e-3, 2e-3, 2e-3);
  existing[3].radius = 1.0;
  existing[3].position = Eigen::Vector3d(10.0, 10.0, 10.0);
  const auto p = insert_random_fill(request, existing);
  ASSERT_EQ(p.size(), 1000u);
  expect_valid_packing(p, request.region, {existing[0], existing[1], existing[2]});
}

TEST(Insertion, RandomFillIsDeterministicPerSeed) {
  FillRequest request = polydisperse_request();
  request.count = 500;
  const auto a = insert_random_fill(request);
  const auto b = insert_random_fill(request);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].radius, b[i].radius);  // bit for bit, not approximately
    EXPECT_EQ(a[i].position, b[i].position);
  }
  request.seed = 43;
  const auto c = insert_random_fill(request);
  ASSERT_EQ(c.size(), a.size());
  std::size_t same = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].radius == c[i].radius || a[i].position == c[i].position) ++same;
  }
  EXPECT_EQ(same, 0u);
}

TEST(Insertion, RandomFillReturnsExactCount) {
  for (const std::size_t n : {1u, 7u, 300u}) {
    FillRequest request;
    request.region = make_box(0, 0, 0, 1, 1, 1);
    request.radius = constant_radius(0.05);
    request.count = n;
    EXPECT_EQ(insert_random_fill(request).size(), n);
  }
}

TEST(Insertion, SolidFractionFillReachesTargetWithinOneParticle) {
  FillRequest request;
  request.region = make_box(0, 0, 0, 6e-3, 6e-3, 6e-3);
  request.radius = uniform_radius(0.1e-3, 0.5e-3);
  request.solid_fraction = 0.3;
  request.seed = 7;
  const auto p = insert_random_fill(request);
  const double region_volume = 216e-9;
  const double target = 0.3 * region_volume;
  const double largest = std::max_element(p.begin(), p.end(), [](const auto& a, const auto& b) {
                           return a.radius < b.radius;
                         })->radius;
  const double v = total_volume(p);
  EXPECT_GE(v, target);
  EXPECT_LT(v - target, sphere_volume(largest));
  expect_valid_packing(p, request.region);
}

TEST(Insertion, NormalRadiusMatchesMeanAndStd) {
  RadiusDistribution d;
  d.kind = RadiusDistribution::Kind::kNormal;
  d.mean = 1e-3;
  d.std_dev = 1e-4;  // the r > 0 cut is 10 sigma away: no visible truncation
  Rng rng(11);
  const int n = 20000;
  double sum = 0.0, sum2 = 0.0;
  for (int k = 0; k < n; ++k) {
    const double r = draw_radius(d, rng);
    sum += r;
    sum2 += r * r;
  }
  const double mean = sum / n;
  const double std_dev = std::sqrt((sum2 - n * mean * mean) / (n - 1));
  // 5 standard errors: sigma/sqrt(n) for the mean, sigma/sqrt(2(n-1)) for the std of a normal.
  EXPECT_NEAR(mean, d.mean, 5.0 * d.std_dev / std::sqrt(n));
  EXPECT_NEAR(std_dev, d.std_dev, 5.0 * d.std_dev / std::sqrt(2.0 * (n - 1)));
}

TEST(Insertion, LogNormalRadiusMatchesMedianAndLogStd) {
  RadiusDistribution d;
  d.kind = RadiusDistribution::Kind::kLogNormal;
  d.median = 0.2e-3;
  d.sigma = 0.4;
  Rng rng(12);
  const int n = 20000;
  std::vector<double> logs(n);
  double sum = 0.0, sum2 = 0.0;
  for (double& l : logs) {
    l = std::log(draw_radius(d, rng));
    sum += l;
    sum2 += l * l;
  }
  std::nth_element(logs.begin(), logs.begin() + n / 2, logs.end());
  const double log_median = logs[n / 2];
  const double mean = sum / n;
  const double log_std = std::sqrt((sum2 - n * mean * mean) / (n - 1));
  // Standard error of a sample median: 1 / (2 f(median) sqrt(n)) = sigma sqrt(pi/2) / sqrt(n)
  // for the normal ln r; of the sample std: sigma / sqrt(2(n-1)). Compare at 5 of each.
  EXPECT_NEAR(log_median, std::log(d.median),
              5.0 * d.sigma * std::sqrt(std::numbers::pi / 2) / std::sqrt(n));
  EXPECT_NEAR(log_std, d.sigma, 5.0 * d.sigma / std::sqrt(2.0 * (n - 1)));
}

TEST(Insertion, CutOffsAreRespected) {
  RadiusDistribution normal;
  normal.kind = RadiusDistribution::Kind::kNormal;
  normal.mean = 1e-3;
  normal.std_dev = 3e-4;
  normal.min = 0.9e-3;
  normal.max = 1.2e-3;
  RadiusDistribution lognormal;
  lognormal.kind = RadiusDistribution::Kind::kLogNormal;
  lognormal.median = 1e-3;
  lognormal.sigma = 0.5;
  lognormal.min = 0.5e-3;
  lognormal.max = 1.5e-3;
  RadiusDistribution uniform = uniform_radius(0.3e-3, 0.4e-3);
  Rng rng(13);
  for (const RadiusDistribution& d : {normal, lognormal, uniform}) {
    double lo = 1.0, hi = 0.0;
    for (int k = 0; k < 5000; ++k) {
      const double r = draw_radius(d, rng);
      lo = std::min(lo, r);
      hi = std::max(hi, r);
    }
    EXPECT_GE(lo, d.min);
    EXPECT_LE(hi, d.max);
    // Each window keeps a sizeable share of the density near both cut-offs: they are reached.
    EXPECT_LT(lo, d.min + 0.01 * (d.max - d.min));
    EXPECT_GT(hi, d.max - 0.01 * (d.max - d.min));
  }
  // A window far in the tail rejects every draw: a clear error instead of an endless loop.
  normal.min = 5e-3;
  normal.max = 6e-3;
  EXPECT_THROW(draw_radius(normal, rng), std::invalid_argument);
}

TEST(Insertion, ImpossibleTargetsThrowInsertionError) {
  FillRequest dense;
  dense.region = make_box(0, 0, 0, 10e-3, 10e-3, 10e-3);
  dense.radius = uniform_radius(0.1e-3, 0.5e-3);
  dense.solid_fraction = 0.6;
  try {
    insert_random_fill(dense);
    ADD_FAILURE() << "solid fraction 0.6 accepted";
  } catch (const InsertionError& e) {
    EXPECT_NE(std::string(e.what()).find("pour"), std::string::npos) << e.what();
  }

  FillRequest crowded;
  crowded.region = make_box(0, 0, 0, 10e-3, 10e-3, 10e-3);
  crowded.radius = constant_radius(1e-3);
  crowded.count = 1000;
  EXPECT_THROW(insert_random_fill(crowded), InsertionError);

  // Below the refusal limit but above what RSA reaches next to walls: placement runs out of tries.
  crowded.count = 90;  // solid fraction 0.377
  crowded.max_attempts_per_particle = 200;
  try {
    insert_random_fill(crowded);
    ADD_FAILURE() << "jammed fill accepted";
  } catch (const InsertionError& e) {
    EXPECT_NE(std::string(e.what()).find("200 attempts"), std::string::npos) << e.what();
  }
}

TEST(Insertion, RandomFillRejectsInvalidRequests) {
  FillRequest ok;
  ok.region = make_box(0, 0, 0, 1, 1, 1);
  ok.radius = constant_radius(0.05);
  ok.count = 10;
  EXPECT_NO_THROW(insert_random_fill(ok));

  FillRequest both = ok;
  both.solid_fraction = 0.1;
  EXPECT_THROW(insert_random_fill(both), std::invalid_argument);
  FillRequest neither = ok;
  neither.count = 0;
  EXPECT_THROW(insert_random_fill(neither), std::invalid_argument);
  FillRequest inverted = ok;
  inverted.radius = uniform_radius(0.05, 0.01);
  EXPECT_THROW(insert_random_fill(inverted), std::invalid_argument);
  FillRequest too_big = ok;
  too_big.radius = constant_radius(0.6);
  EXPECT_THROW(insert_random_fill(too_big), std::invalid_argument);
  FillRequest flat = ok;
  flat.region.max.z() = 0.0;
  EXPECT_THROW(insert_random_fill(flat), std::invalid_argument);
  FillRequest no_tries = ok;
  no_tries.max_attempts_per_particle = 0;
  EXPECT_THROW(insert_random_fill(no_tries), std::invalid_argument);
  FillRequest no_spread = ok;
  no_spread.radius.kind = RadiusDistribution::Kind::kNormal;
  no_spread.radius.mean = 0.05;
  EXPECT_THROW(insert_random_fill(no_spread), std::invalid_argument);
  // An uncapped normal that draws a radius larger than the region asks for a max cut-off.
  FillRequest uncapped = ok;
  uncapped.radius.kind = RadiusDistribution::Kind::kNormal;
  uncapped.radius.mean = 0.4;
  uncapped.radius.std_dev = 0.2;
  uncapped.count = 100;
  uncapped.region.max.z() = 100.0;  // room for 100 such spheres: the radius, not the count, fails
  EXPECT_THROW(insert_random_fill(uncapped), std::invalid_argument);
}

TEST(Insertion, FewTinyParticlesInHugeBoxUseBoundedGrid) {
  // 1e-6 m spheres in a 1 m box would need 1e17 cells at edge 2r; the grid is capped instead.
  FillRequest request;
  request.region = make_box(0, 0, 0, 1, 1, 1);
  request.radius = constant_radius(1e-6);
  request.count = 50;
  const auto p = insert_random_fill(request);
  EXPECT_EQ(p.size(), 50u);
  expect_valid_packing(p, request.region);
}

TEST(Insertion, ManyParticlesInsertQuickly) {
  // 50000 monodisperse spheres at solid fraction 0.25: seconds would mean the grid is not used.
  FillRequest request;
  request.region = make_box(0, 0, 0, 1, 1, 1);
  request.radius = constant_radius(std::cbrt(0.25 / 50000 / (4.0 / 3.0 * std::numbers::pi)));
  request.count = 50000;
  const auto p = insert_random_fill(request);
  EXPECT_EQ(p.size(), 50000u);
  EXPECT_NEAR(total_volume(p), 0.25, 1e-9);
}

}  // namespace
}  // namespace bondem
