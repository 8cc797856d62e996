// Two-particle collisions through the full scene / kernel / integrator path: the paper's
// examples 5.1 and 5.2 and the Hertz limits.
#include <gtest/gtest.h>

#include <cmath>

#include "io/case_file.hpp"
#include "solver/experiments/calculator.hpp"
#include "solver/experiments/collision.hpp"

namespace bondem {
namespace {

Case paper_case(const std::vector<std::string>& overrides = {}) {
  return load_case(BONDEM_CASES_DIR "/paper_5_1.yaml", overrides);
}

double critical_velocity_of(const Case& c) {
  return compute_pair_report(c, 0, c.particles[0].radius, 0, c.particles[1].radius, 1.0)
      .critical_velocity;
}

// Example 5.1: the bond forms at 2.6 m/s and the overlap settles at delta_eq whatever xi_bond.
// 0.005 s is at least 50 decay times 1/(xi omega) of the bond oscillation for xi >= 0.1, so the
// residual oscillation is far below the 0.1 % asked for.
class SettlesAtEquilibrium : public ::testing::TestWithParam<double> {};

TEST_P(SettlesAtEquilibrium, OverlapWithinPointOnePercent) {
  const Case c = paper_case({"bond.damping_ratio=" + std::to_string(GetParam())});
  const CollisionResult r = collide(c, 2.6);
  EXPECT_TRUE(r.bonded);
  EXPECT_EQ(r.restitution, 0.0);
  EXPECT_FALSE(r.contact_time.has_value());
  EXPECT_NEAR(r.final_overlap, 5e-5, 1e-3 * 5e-5);
}

INSTANTIATE_TEST_SUITE_P(Paper51, SettlesAtEquilibrium, ::testing::Values(0.1, 0.25, 0.5, 1.0));

// Example 5.2: with an undamped approach the threshold is eq. 21. A 2 % margin in speed is 1.6 %
// in maximum overlap (delta_max ~ v^0.8), while sampling the peak every 0.5 us misses it by
// about 1e-8 m (0.05 % of delta_crit): the margin is thirty times the numerical error.
class ThresholdAtCriticalVelocity : public ::testing::TestWithParam<int> {};

TEST_P(ThresholdAtCriticalVelocity, SticksAboveReboundsBelow) {
  const Case c = load_case(BONDEM_CASES_DIR "/paper_5_2.yaml",
                           {"materials.powder.density=" + std::to_string(GetParam())});
  const double v_crit = critical_velocity_of(c);
  const CollisionResult above = collide(c, 1.02 * v_crit);
  EXPECT_TRUE(above.bonded) << "v = " << 1.02 * v_crit;
  EXPECT_EQ(above.restitution, 0.0);
  const CollisionResult below = collide(c, 0.98 * v_crit);
  EXPECT_FALSE(below.bonded) << "v = " << 0.98 * v_crit;
  EXPECT_FALSE(below.bond_formed);
  EXPECT_NEAR(below.restitution, 1.0, 1e-3);  // undamped Hertz rebound
}

INSTANTIATE_TEST_SUITE_P(Paper52, ThresholdAtCriticalVelocity,
                         ::testing::Values(500, 1000, 2000, 3000, 4000, 5000, 6000, 7000, 8000));

TEST(Collision, UndampedHertzMatchesEq20AndContactTime) {
  const Case c = paper_case({"bond.criterion=never"});
  const double v = 1.0;
  const CollisionResult r = collide(c, v);
  const PairReport report = compute_pair_report(c, 0, 1e-3, 0, 1e-3, v);
  ASSERT_TRUE(r.contact_time.has_value());
  // ~60 steps per contact: the sampled peak and the interpolated end are good to (dt/t_c)^2.
  EXPECT_NEAR(r.max_overlap, report.max_overlap, 1e-3 * report.max_overlap);
  EXPECT_NEAR(*r.contact_time, report.contact_time, 2e-3 * report.contact_time);
  EXPECT_NEAR(r.restitution, 1.0, 1e-4);
}

TEST(Collision, DampedHertzRestitutionIndependentOfSpeed) {
  // Tsuji-type damping (eq. 26) makes e a function of xi_con only. Over a 50x range of speeds
  // the contact lasts 30-65 steps; the discretization error of e is then below 1e-3.
  const Case c = paper_case({"bond.criterion=never", "contact.damping_ratio=0.2"});
  const double reference = collide(c, 1.0).restitution;
  EXPECT_LT(reference, 0.8);  // damping acts
  EXPECT_GT(reference, 0.4);
  for (double v : {0.1, 0.3, 3.0, 5.0}) {
    EXPECT_NEAR(collide(c, v).restitution, reference, 1e-3) << "v = " << v;
  }
}

TEST(Collision, NeverCriterionAlwaysRebounds) {
  const CollisionResult r = collide(paper_case({"bond.criterion=never"}), 5.0);
  EXPECT_FALSE(r.bond_formed);
  EXPECT_GT(r.restitution, 0.99);
}

TEST(Collision, UnequalPairSettlesAtItsEquilibrium) {
  // Different radii and densities: zero total momentum placement and eq. 13 with the pair's r*.
  const Case c = paper_case(
      {"particles.1.radius=0.002", "particles.1.position.0=0.003", "bond.damping_ratio=1"});
  const double v = 1.5 * critical_velocity_of(c);
  const CollisionResult r = collide(c, v);
  EXPECT_TRUE(r.bonded);
  EXPECT_NEAR(r.final_overlap, 5e-5, 1e-3 * 5e-5);
}

TEST(Collision, RefusesCasesWithoutTwoParticles) {
  Case c = paper_case();
  c.particles.pop_back();
  EXPECT_THROW(collide(c, 1.0), std::invalid_argument);
  EXPECT_THROW(collide(paper_case(), -1.0), std::invalid_argument);
}

}  // namespace
}  // namespace bondem
