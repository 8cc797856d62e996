// Case-reader checks (issue 12: overlaps, counts, materials, periodic axes, --set paths).
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <vector>

#include "case_text.hpp"
#include "io/case_file.hpp"
#include "solver/setup/insertion.hpp"

namespace bondem {
namespace {

/// Two touching spheres of radius 1 mm; line 1 holds the materials key.
const std::string kPair = R"(materials:
  powder: {density: 2000, youngs_modulus: 1.0e9, poisson_ratio: 0.0}
contact: {damping_ratio: 0.1}
time: {step: 5.0e-7, end: 0.005}
particles:
  - {material: powder, radius: 0.001, position: [0, 0, 0]}
  - {material: powder, radius: 0.001, position: [0.002, 0, 0]}
)";

using testing::error_of;
using testing::replace;

const std::string kPowder =
    "  powder: {density: 2000, youngs_modulus: 1.0e9, poisson_ratio: 0.0}\n";

TEST(ReaderChecks, MaterialDefinedTwiceIsRefused) {
  ASSERT_EQ(error_of(kPair), "");
  // The second definition would be silently ignored (lookups see the first).
  const std::string twice =
      replace(kPair, kPowder,
              kPowder + "  powder: {density: 9000, youngs_modulus: 2.0e9, poisson_ratio: 0.3}\n");
  EXPECT_EQ(error_of(twice), "case.yaml:3:3: 'materials.powder': material defined twice");
}

TEST(ReaderChecks, NonScalarMaterialKeyIsRefused) {
  // A list and a mapping as keys: both used to become a material named "".
  const std::string flow_key =
      replace(kPair, "materials:\n" + kPowder,
              "materials: {[a, b]: {density: 1, youngs_modulus: 1, poisson_ratio: 0}}\n");
  const std::string complex_key =
      replace(kPair, kPowder,
              kPowder + "  ? {x: 1}\n  : {density: 1, youngs_modulus: 1, poisson_ratio: 0}\n");
  const std::string message = error_of(complex_key);
  EXPECT_NE(message.find("case.yaml:3:5: 'materials': a material's name must be a plain"),
            std::string::npos)
      << message;
  EXPECT_NE(error_of(flow_key).find("case.yaml:1:13: 'materials': a material's name must be"),
            std::string::npos)
      << error_of(flow_key);
}

TEST(ReaderChecks, MalformedSetPathsNameTheSet) {
  // Each is a --set at fault: the message must start with it, not with the case file.
  const std::vector<std::string> malformed = {"a.=1",
                                              "time.end.=1e-4",
                                              ".time.end=1",
                                              "time..end=1",
                                              "particles.99999999999999999999.radius=1",
                                              "particles.+1.radius=1",
                                              "particles.-1.radius=1"};
  for (const std::string& set : malformed) {
    const std::string message = error_of(kPair, {set});
    EXPECT_EQ(message.rfind("--set " + set + ":", 0), 0u) << set << " gave: " << message;
    EXPECT_EQ(message.find("stoul"), std::string::npos) << message;
  }
  // A well-formed one still works.
  EXPECT_EQ(error_of(kPair, {"time.end=1e-4", "particles.1.radius=0.001"}), "");
}

// Item 6: one initial-overlap check over all particles, at the run's own limit.

// Issue 12 item 4: a speed of 1e300 m/s made the time-step limit NaN, which switched its check off.
TEST(ReaderChecks, UnphysicalSpeedIsRefusedNamingTheSetOrTheLine) {
  const std::string moving =
      replace(kPair, "position: [0, 0, 0]}", "position: [0, 0, 0], velocity: [1, 0, 0]}");
  EXPECT_EQ(error_of(moving, {"particles.0.velocity.0=2.9e8"}), "");
  const std::string by_set = error_of(moving, {"particles.0.velocity.0=1e300"});
  EXPECT_NE(by_set.find("--set particles.0.velocity.0=1e300: 'particles.0.velocity': a speed of "
                        "1e+300 m/s is not physical"),
            std::string::npos)
      << by_set;
  const std::string in_file = error_of(
      replace(kPair, "position: [0, 0, 0]}", "position: [0, 0, 0], velocity: [0, 0, -3e8]}"));
  EXPECT_NE(in_file.find("case.yaml:6:"), std::string::npos) << in_file;
  EXPECT_NE(in_file.find("'particles.0.velocity'"), std::string::npos) << in_file;
}

// Values that no solid has made the derived masses, stiffnesses and the time-step limit NaN or
// infinite (issue 12 item 4); an equilibrium overlap past the run's own overlap limit made every
// bonded pair stop the run.
TEST(ReaderChecks, AbsurdMaterialsAndEquilibriumOverlapAreRefused) {
  const std::string bonded =
      kPair +
      "bond: {alpha: 1, equilibrium_overlap: 5.0e-5, damping_ratio: 0.5, criterion: always}\n";
  ASSERT_EQ(error_of(bonded), "");
  EXPECT_EQ(error_of(kPair, {"materials.powder.density=1e308"}),
            "--set materials.powder.density=1e308: 'materials.powder.density': must not exceed "
            "1e6 kg/m^3");
  EXPECT_EQ(error_of(kPair, {"materials.powder.youngs_modulus=1e308"}),
            "--set materials.powder.youngs_modulus=1e308: 'materials.powder.youngs_modulus': must "
            "not exceed 1e14 Pa");
  // 0.25 of the 1 mm radius is the limit: just below it is accepted, at it refused.
  EXPECT_EQ(error_of(bonded, {"bond.equilibrium_overlap=2.49e-4"}), "");
  const std::string at_limit = error_of(bonded, {"bond.equilibrium_overlap=2.5e-4"});
  EXPECT_NE(at_limit.find("'bond.equilibrium_overlap': 0.00025 m is not below "
                          "limits.max_overlap_fraction (0.25)"),
            std::string::npos)
      << at_limit;
  // Without bonding the placeholder is not checked.
  EXPECT_EQ(error_of(kPair), "");
}

TEST(ReaderChecks, OverlapsUpToTheRunsLimitAreAcceptedBeyondItRefused) {
  // 0.1 mm of overlap on radii of 1 mm is 0.1 of the smaller radius: within the default 0.25.
  EXPECT_EQ(error_of(kPair, {"particles.1.position.0=0.0019"}), "");
  EXPECT_NE(
      error_of(kPair + "limits: {max_overlap_fraction: 0.05}\n", {"particles.1.position.0=0.0019"})
          .find("--set particles.1.position.0=0.0019: 'particles.1': overlaps particles.0 by 0.1 "
                "of the smaller "
                "radius, more than limits.max_overlap_fraction = 0.05"),
      std::string::npos)
      << error_of(kPair + "limits: {max_overlap_fraction: 0.05}\n",
                  {"particles.1.position.0=0.0019"});
  EXPECT_NE(error_of(kPair, {"particles.1.position.0=0.0015"})
                .find("'particles.1': overlaps particles.0"),
            std::string::npos);
}

TEST(ReaderChecks, LatticeWithSpacingFarBelowItsDiameterIsRefusedBeforeItIsMade) {
  const std::string lattice = kPair + R"(insert:
  - {type: lattice, region: {min: [0.01, 0, 0], max: [0.02, 0.01, 0.01]}, spacing: 0.0021, radius: 0.001, material: powder}
)";
  EXPECT_EQ(error_of(lattice), "");
  // Neighbors 0.2 mm apart on radii of 1 mm overlap by 1.8 radii.
  const std::string message = error_of(lattice, {"insert.0.spacing=0.0002"});
  EXPECT_NE(message.find("'insert.0.spacing': neighbors of the lattice overlap by 1.8 of their "
                         "radius, more than limits.max_overlap_fraction = 0.25"),
            std::string::npos)
      << message;
  // A spacing that would make 10^21 particles (size_t overflowed in the product before) is
  // refused at once, without allocating.
  const auto start = std::chrono::steady_clock::now();
  const std::string huge = error_of(lattice, {"insert.0.spacing=1e-9"});
  EXPECT_NE(huge.find("particles, more than the limit of 1e+08 per insertion"), std::string::npos)
      << huge;
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(1));
}

TEST(ReaderChecks, LatticeOverAnExplicitParticleIsRefused) {
  // The lattice's first sphere sits at (0.0105, 0.0005, 0.0005); the explicit one 0.5 mm away.
  const std::string over =
      kPair + R"(  - {material: powder, radius: 0.0005, position: [0.0105, 0.001, 0.0005]}
insert:
  - {type: lattice, region: {min: [0.01, 0, 0], max: [0.02, 0.01, 0.01]}, spacing: 0.001, radius: 0.0005, material: powder}
)";
  const std::string message = error_of(over);
  EXPECT_NE(message.find("case.yaml:10:5: 'insert.0': its particle at [0.0105, 0.0005, 0.0005] "
                         "overlaps particles.2 by 1 of the smaller radius"),
            std::string::npos)
      << message;
}

TEST(ReaderChecks, OverlapAcrossAPeriodicBoundaryIsRefused) {
  // Periodic x of 10 mm: spheres at x = 0.5 mm and 9.7 mm are 0.8 mm apart through the face.
  const std::string periodic =
      kPair +
      R"(domain: {min: [-0.005, -0.005, -0.005], max: [0.005, 0.005, 0.005], periodic: [true, false, false]}
)";
  const std::vector<std::string> apart = {"particles.0.position.0=-0.0045",
                                          "particles.1.position.0=0.0047"};
  const std::string message = error_of(periodic, apart);
  EXPECT_NE(message.find("'particles.1': overlaps particles.0 across the periodic boundary by 1.2"),
            std::string::npos)
      << message;
  EXPECT_EQ(error_of(periodic, {"particles.0.position.0=-0.0045", "particles.1.position.0=0.0035"}),
            "");
}

TEST(ReaderChecks, RandomFillCountThatCannotFitIsRefusedBeforeDrawing) {
  const std::string fill = kPair + R"(insert:
  - {type: random, region: {min: [0.01, 0, 0], max: [0.02, 0.01, 0.01]}, count: 10, radius: 0.0005, material: powder}
)";
  EXPECT_EQ(error_of(fill), "");
  const auto start = std::chrono::steady_clock::now();
  const std::string constant = error_of(fill, {"insert.0.count=100000000"});
  EXPECT_NE(
      constant.find("--set insert.0.count=100000000: 'insert.0': random fill: count 100000000 even "
                    "at the smallest "
                    "possible radius: solid fraction"),
      std::string::npos)
      << constant;
  // Without a lower cut-off drawing stops as soon as the drawn volume passes the limit.
  const std::string lognormal =
      error_of(replace(fill, "radius: 0.0005,",
                       "radius: {distribution: lognormal, median: 0.0005, sigma: 0.2},"),
               {"insert.0.count=100000000"});
  EXPECT_NE(lognormal.find("the first "), std::string::npos) << lognormal;
  EXPECT_NE(lognormal.find(" of 100000000 drawn particles have solid fraction"), std::string::npos)
      << lognormal;
  // Before: 15-18 s and 1 GB for the 10^8 radii.
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(1));
}

/// All-pairs reference of find_initial_overlap.
std::optional<InitialOverlap> all_pairs_overlap(const std::vector<ParticleSpec>& particles,
                                                const Domain& domain, double max_fraction) {
  const Eigen::Vector3d length = domain.length();
  for (std::size_t i = 1; i < particles.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      Eigen::Vector3d d = particles[j].position - particles[i].position;
      for (int a = 0; a < 3; ++a) {
        if (domain.periodic[a]) d[a] -= length[a] * std::round(d[a] / length[a]);
      }
      const double smaller = std::min(particles[i].radius, particles[j].radius);
      const double overlap = particles[i].radius + particles[j].radius - d.norm();
      if (overlap > max_fraction * smaller) return InitialOverlap{i, j, overlap / smaller, false};
    }
  }
  return std::nullopt;
}

TEST(ReaderChecks, GridOverlapSearchAgreesWithAllPairs) {
  // Polydisperse (8:1) spheres at random in a box, some periodic axes: the first offending pair
  // (smallest later, then smallest earlier index) must be the all-pairs one, for every limit.
  Rng rng(7);
  for (int trial = 0; trial < 40; ++trial) {
    Domain domain;
    domain.max = Eigen::Vector3d(0.01, 0.004, 0.006);
    domain.periodic = {trial % 2 == 0, trial % 3 == 0, false};
    std::vector<ParticleSpec> particles(300);
    for (ParticleSpec& p : particles) {
      p.radius = 0.5e-4 * (1.0 + 7.0 * uniform01(rng));
      for (int a = 0; a < 3; ++a) p.position[a] = domain.max[a] * uniform01(rng);
    }
    for (const double limit : {0.05, 0.5, 0.95}) {
      const auto expected = all_pairs_overlap(particles, domain, limit);
      const auto found = find_initial_overlap(particles, &domain, limit);
      ASSERT_EQ(found.has_value(), expected.has_value()) << trial << " " << limit;
      if (!found) continue;
      EXPECT_EQ(found->later, expected->later) << trial << " " << limit;
      EXPECT_EQ(found->earlier, expected->earlier) << trial << " " << limit;
      EXPECT_DOUBLE_EQ(found->fraction, expected->fraction);
    }
  }
}

TEST(ReaderChecks, OverlapSearchInChunksFindsTheFirstOverlapOnAnyThreadCount) {
  // 27 000 spheres on a cubic lattice with gaps, two planted overlaps in different chunks of the
  // parallel search (4 096 particles each): the one with the smaller later index is the answer,
  // however the chunks are spread over threads.
  Domain domain;
  domain.max = Eigen::Vector3d(0.09, 0.09, 0.09);
  const double radius = 1.0e-3;
  std::vector<ParticleSpec> particles;
  for (int z = 0; z < 30; ++z) {
    for (int y = 0; y < 30; ++y) {
      for (int x = 0; x < 30; ++x) {
        ParticleSpec p;
        p.radius = radius;
        p.position = Eigen::Vector3d(x, y, z) * 3.0 * radius + Eigen::Vector3d::Constant(radius);
        particles.push_back(p);
      }
    }
  }
  particles[20000].position = particles[19999].position + Eigen::Vector3d(0.5 * radius, 0, 0);
  particles[9000].position = particles[100].position + Eigen::Vector3d(0, 0.5 * radius, 0);
  const int threads = omp_get_max_threads();
  for (const int team : {1, 2, 3}) {
    omp_set_num_threads(team);
    const auto found = find_initial_overlap(particles, &domain, 0.05);
    ASSERT_TRUE(found.has_value()) << team;
    EXPECT_EQ(found->later, 9000U) << team;
    EXPECT_EQ(found->earlier, 100U) << team;
    EXPECT_DOUBLE_EQ(found->fraction, 1.5) << team;  // 2r - r/2 over r
  }
  omp_set_num_threads(threads);
}

// Item 8: a periodic axis shorter than three neighbor cells is a reader error naming the key.

TEST(ReaderChecks, PeriodicAxisShorterThanThreeNeighborCellsIsRefused) {
  // Periodic y of 6 mm; radii of 1 mm: cells of 2 mm + skin (default 0.2 mm) make 2.7 < 3.
  const std::string periodic =
      kPair +
      R"(domain: {min: [-0.01, -0.003, -0.01], max: [0.01, 0.003, 0.01], periodic: [false, true, false]}
)";
  const std::string by_default = error_of(periodic);
  EXPECT_NE(by_default.find("case.yaml:8:75: 'domain.periodic': periodic axis y of length 0.006 m "
                            "is shorter than three neighbor cells of 0.0022 m"),
            std::string::npos)
      << by_default;
  EXPECT_EQ(error_of(periodic, {"domain.max.1=0.0036"}), "");  // 6.6 mm: exactly three cells
  const std::string with_skin = periodic + "neighbors: {skin: 0.001}\n";
  const std::string skin_named = error_of(with_skin, {"domain.max.1=0.0036"});
  EXPECT_NE(skin_named.find("case.yaml:9:19: 'neighbors.skin': periodic axis y of length 0.0066 m "
                            "is shorter than three neighbor cells of 0.003 m"),
            std::string::npos)
      << skin_named;
  EXPECT_NE(skin_named.find("the skin must be below 0.0002 m"), std::string::npos) << skin_named;
}

// Docs item: D-values of a lognormal are volume-weighted by default (laser diffraction), or
// number-weighted on request.

/// The diameter below which @p fraction of the sample lies, weighted by volume or by number.
double sample_d_value(std::vector<double> radii, double fraction, SizeWeighting weighting) {
  std::sort(radii.begin(), radii.end());
  const auto weight = [&](double r) {
    return weighting == SizeWeighting::kVolume ? r * r * r : 1.0;
  };
  double total = 0.0;
  for (const double r : radii) total += weight(r);
  double below = 0.0;
  for (const double r : radii) {
    below += weight(r);
    if (below >= fraction * total) return 2.0 * r;
  }
  return 2.0 * radii.back();
}

TEST(ReaderChecks, VolumeWeightedDValuesAreReproducedBySampledRadii) {
  // D10, D50, D90 = 50, 75, 100 um: sigma = ln 2 / 2.563 = 0.270, so the number median is
  // exp(-3 sigma^2) = 0.803 of the volume one (Hatch-Choate).
  const double d10 = 50e-6, d50 = 75e-6, d90 = 100e-6;
  for (const SizeWeighting weighting : {SizeWeighting::kVolume, SizeWeighting::kNumber}) {
    const RadiusDistribution distribution = lognormal_from_d_values(d10, d50, d90, weighting);
    Rng rng(11);
    std::vector<double> radii(400000);
    for (double& r : radii) r = draw_radius(distribution, rng);
    // 4e5 draws: the quantiles' sampling error is about 0.1 % (volume weighting leaves fewer
    // effective samples); 1 % is ten of those, and the two weightings differ by 20 %.
    EXPECT_NEAR(sample_d_value(radii, 0.5, weighting), d50, 0.01 * d50);
    // A log-normal has D10 D90 = D50^2; these data do not (5000 vs 5625 um^2), so the fit keeps
    // D50 and the spread D90/D10, i.e. D10 and D90 at D50 / sqrt(2) and D50 sqrt(2).
    const double spread = std::sqrt(d90 / d10);
    EXPECT_NEAR(sample_d_value(radii, 0.1, weighting), d50 / spread, 0.01 * d10);
    EXPECT_NEAR(sample_d_value(radii, 0.9, weighting), d50 * spread, 0.01 * d90);
  }
  const double sigma = std::log(d90 / d10) / (2.0 * 1.2815515655446004);
  EXPECT_DOUBLE_EQ(lognormal_from_d_values(d10, d50, d90, SizeWeighting::kVolume).median,
                   0.5 * d50 * std::exp(-3.0 * sigma * sigma));
}

TEST(ReaderChecks, LognormalDValuesAreByVolumeUnlessWeightingSaysNumber) {
  const std::string fill = kPair + R"(insert:
  - {type: random, region: {min: [0.01, 0, 0], max: [0.02, 0.01, 0.01]}, count: 2000, material: powder, radius: {distribution: lognormal, d10: 50.0e-6, d50: 75.0e-6, d90: 100.0e-6}}
)";
  // Median of the 2000 inserted radii: its sampling error is about 1.25 sigma / sqrt(2000) =
  // 0.8 %; 5 % is six of those, and the two weightings differ by 20 %.
  const auto median_radius = [](const std::string& text) {
    const Case c = parse_case(text, "case.yaml");
    std::vector<double> radii;
    for (std::size_t k = 2; k < c.particles.size(); ++k) radii.push_back(c.particles[k].radius);
    std::sort(radii.begin(), radii.end());
    return radii[radii.size() / 2];
  };
  const double sigma = std::log(2.0) / (2.0 * 1.2815515655446004);
  EXPECT_NEAR(median_radius(fill), 37.5e-6 * std::exp(-3.0 * sigma * sigma), 0.05 * 30e-6);
  EXPECT_NEAR(median_radius(replace(fill, "d90: 100.0e-6}", "d90: 100.0e-6, weighting: number}")),
              37.5e-6, 0.05 * 37.5e-6);
  EXPECT_NE(error_of(replace(fill, "d90: 100.0e-6}", "d90: 100.0e-6, weighting: mass}"))
                .find("'insert.0.radius.weighting': unknown weighting 'mass' (volume or number)"),
            std::string::npos);
  const std::string by_median =
      replace(fill, "d10: 50.0e-6, d50: 75.0e-6, d90: 100.0e-6", "median: 3.0e-5, sigma: 0.2");
  EXPECT_EQ(error_of(by_median), "");
  EXPECT_NE(error_of(replace(by_median, "sigma: 0.2", "sigma: 0.2, weighting: volume"))
                .find("'insert.0.radius.weighting': only with d10, d50 and d90"),
            std::string::npos);
}

}  // namespace
}  // namespace bondem
