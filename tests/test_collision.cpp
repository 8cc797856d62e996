// Two-particle collisions through the full scene / kernel / integrator path: the paper's
// examples 5.1 and 5.2, the Hertz limits, restitution as input and JKR sticking.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <tuple>

#include "io/case_file.hpp"
#include "solver/engine/scene.hpp"
#include "solver/experiments/calculator.hpp"
#include "solver/experiments/collision.hpp"
#include "solver/models/cohesion_law.hpp"
#include "solver/models/pair.hpp"

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
  c.particles.expanded().pop_back();
  EXPECT_THROW(collide(c, 1.0), std::invalid_argument);
  EXPECT_THROW(collide(paper_case(), -1.0), std::invalid_argument);
}

// Restitution as input (issue 14): the damper derived from e (restitution.hpp, exact for the
// clamped laws) gives back e within 1 % at 0.1, 1 and 5 m/s. The error is the integrator's: the
// damper sees a velocity half a step old, first order in omega dt. With 2.5e-7 s a Hertz contact
// takes 90 (5 m/s) to 350 (0.1 m/s) steps and a linear one (k = 1e4 N/m) 257 to 354; measured
// at most 0.38 % (Hertz, e = 0.2, 5 m/s) and 0.43 % (linear, e = 0.1). Hertz e = 0.1 (xi = 1.13)
// needs twice the steps: 1.03 % at 158 steps, 0.62 % at 318 (time.step 1.25e-7).
using RestitutionParam = std::tuple<std::string, double, std::string>;  // law, e, time step

class RestitutionAsInput : public ::testing::TestWithParam<RestitutionParam> {};

TEST_P(RestitutionAsInput, MeasuredWithinOnePercentFromSlowToFast) {
  const auto& [law, e, step] = GetParam();
  std::vector<std::string> overrides = {"contact.restitution=" + std::to_string(e),
                                        "time.step=" + step};
  if (law == "hooke") {
    overrides.insert(overrides.end(), {"contact.normal_law=hooke", "contact.stiffness=1e4"});
  }
  const Case c = load_case(BONDEM_TEST_CASES_DIR "/restitution_pair.yaml", overrides);
  for (double v : {0.1, 1.0, 5.0}) {
    const CollisionResult r = collide(c, v);
    ASSERT_TRUE(r.contact_time.has_value()) << law << " e = " << e << ", v = " << v;
    EXPECT_FALSE(r.stuck);
    EXPECT_NEAR(r.restitution, e, 0.01 * e) << law << ", v = " << v;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Laws, RestitutionAsInput,
    ::testing::Values(
        RestitutionParam{"hertz", 0.9, "2.5e-7"}, RestitutionParam{"hertz", 0.5, "2.5e-7"},
        RestitutionParam{"hertz", 0.2, "2.5e-7"}, RestitutionParam{"hertz", 0.1, "1.25e-7"},
        RestitutionParam{"hooke", 0.9, "2.5e-7"}, RestitutionParam{"hooke", 0.5, "2.5e-7"},
        RestitutionParam{"hooke", 0.2, "2.5e-7"},
        // xi = 1.16 > 1: the overdamped branch of the clamped linear law.
        RestitutionParam{"hooke", 0.1, "2.5e-7"}));

// The Hertz error shrinks with the step towards the input: a fourth of the step cuts it by 2.45
// (measured -3.78e-3, -2.56e-3, -1.54e-3 at 2.5e-7, 1.25e-7, 6.25e-8 s for e = 0.2 at 5 m/s: first
// order with a second-order part of opposite sign), so e is the limit, not an offset of the map.
TEST(RestitutionAsInputHertz, ErrorVanishesWithTheStep) {
  const auto error = [](const std::string& step) {
    const Case c = load_case(BONDEM_TEST_CASES_DIR "/restitution_pair.yaml",
                             {"contact.restitution=0.2", "time.step=" + step});
    return collide(c, 5.0).restitution - 0.2;
  };
  const double coarse = error("2.5e-7");
  const double fine = error("6.25e-8");
  EXPECT_GT(std::abs(coarse), 1e-4);  // an error to shrink
  EXPECT_GT(coarse / fine, 2.0);
  EXPECT_LT(coarse / fine, 4.0);
}

// JKR without damping (tests/cases/jkr_pair.yaml): the contact is conservative from the snap-on
// at delta = 0 down and back, and costs the work W to pull it from delta = 0 to the separation
// overlap (jkr_cycle_energy_loss). The pair sticks unless (1/2) m* V^2 > W: V_s = sqrt(2 W / m*),
// = 1.0348 (F_c^5 / (m*^3 E*^2 r*))^(1/6) with F_c the pull-off force, and rebounds with
// e = sqrt(1 - (V_s / V)^2).
struct JkrPair {
  Case c = load_case(BONDEM_TEST_CASES_DIR "/jkr_pair.yaml");
  PairCoefficients coefficients = build_scene(c).pair(0, 0);
  double r_star = 0.5 * c.particles[0].radius;
  double m_star = 0.5 * sphere_mass(c.particles[0].radius, c.materials[0].density);
  double w = coefficients.cohesion_energy;
  double loss = jkr_cycle_energy_loss(r_star, coefficients.effective_modulus, w);
  double v_stick = std::sqrt(2.0 * loss / m_star);
  /// The snap-on force at delta = 0, 8/9 of the pull-off force.
  double snap_force = 8.0 / 9.0 * jkr_pull_off_force(r_star, w);
};

TEST(JkrCollision, SticksSlowReboundsFastAsTheEnergyBalanceSays) {
  const JkrPair pair;
  ASSERT_NEAR(pair.v_stick, 0.40032, 1e-5);  // the value the CLI test uses
  const CollisionResult slow = collide(pair.c, 0.95 * pair.v_stick);
  EXPECT_TRUE(slow.stuck);
  EXPECT_FALSE(slow.bonded);
  EXPECT_EQ(slow.restitution, 0.0);
  EXPECT_FALSE(slow.contact_time.has_value());
  // Held by JKR: the overlap never falls to the separation overlap.
  EXPECT_GT(slow.final_overlap,
            jkr_separation_overlap(pair.r_star, pair.coefficients.effective_modulus, pair.w));
  for (double ratio : {1.05, 2.5}) {
    const double v = ratio * pair.v_stick;
    const CollisionResult fast = collide(pair.c, v);
    EXPECT_FALSE(fast.stuck) << "v = " << v;
    ASSERT_TRUE(fast.contact_time.has_value());
    const double e = std::sqrt(1.0 - 1.0 / (ratio * ratio));
    // The snap-on (8/9 F_c) and release (5/9 F_c) steps each misplace at most one step of their
    // force's work, F v dt: e^2 moves by 2 (13/9 F_c v dt) / (m* v^2).
    const double energy_error = 13.0 / 8.0 * pair.snap_force * v * pair.c.time_step;
    EXPECT_NEAR(fast.restitution, e, energy_error / (pair.m_star * v * v * e)) << "v = " << v;
  }
}

// The bisection lands within 0.1 % of V_s, and the offset is the step's: velocity Verlet kicks
// the pair with half the snap-on force in the first step of contact, so the approach lacks
// (1/2) F_snap V dt of work and the threshold rises by F_snap V_s dt / (4 W) (1.0e-3 here).
// Measured: 0.4019209, 0.4011220, 0.4007223, 0.4005223, 0.4004223 m/s at dt = 8, 4, 2, 1, 0.5 ns;
// Richardson's extrapolation 0.4003223 is V_s = 0.4003224 to 2e-7.
TEST(JkrCollision, ThresholdIsTheClosedFormPlusTheSnapOnStep) {
  const JkrPair pair;
  const auto threshold = sticking_threshold(pair.c, 0.2, 1.0);
  ASSERT_TRUE(threshold.has_value());
  EXPECT_TRUE(threshold->sticks_below);
  EXPECT_NEAR(threshold->velocity, pair.v_stick, 2e-3 * pair.v_stick);
  const double expected =
      pair.v_stick * (1.0 + pair.snap_force * pair.v_stick * pair.c.time_step / (4.0 * pair.loss));
  // Bisection to 1e-6; second-order terms (dt / t_c)^2 ~ 1e-6.
  EXPECT_NEAR(threshold->velocity, expected, 2e-5 * expected);
}

// The bond law keeps its side: sticking above eq. 21's speed, found by the same bisection.
TEST(StickingThreshold, BondLawSticksAboveEq21) {
  const Case c = load_case(BONDEM_CASES_DIR "/paper_5_2.yaml");
  const auto threshold = sticking_threshold(c, 0.5, 8.0);
  ASSERT_TRUE(threshold.has_value());
  EXPECT_FALSE(threshold->sticks_below);
  // 2 % as in ThresholdAtCriticalVelocity.
  EXPECT_NEAR(threshold->velocity, critical_velocity_of(c), 0.02 * critical_velocity_of(c));
  EXPECT_FALSE(sticking_threshold(c, 0.5, 1.0).has_value());  // rebounds at both ends
}

}  // namespace
}  // namespace bondem
