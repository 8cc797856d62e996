// Derived quantities against the equation sheet's table (shared/reference/bond-model.md).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "io/case_file.hpp"
#include "solver/experiments/calculator.hpp"

namespace bondem {
namespace {

Case paper_case() {
  return load_case(BONDEM_CASES_DIR "/paper_5_1.yaml");
}

TEST(Calculator, PaperCaseMatchesSheetTable) {
  const PairReport r = compute_pair_report(paper_case(), 0, 1e-3, 0, 1e-3, 2.6);
  // The sheet quotes six significant digits: compare at that precision.
  EXPECT_NEAR(r.effective_radius, 5e-4, 1e-15);
  EXPECT_NEAR(r.effective_modulus, 5e8, 1e-3);
  EXPECT_NEAR(r.effective_mass, 4.18879e-6, 5e-12);
  EXPECT_NEAR(r.adhesion_stiffness, 1.05409e5, 0.5);
  EXPECT_NEAR(r.critical_overlap, 2.22222e-5, 5e-11);
  EXPECT_NEAR(r.critical_velocity, 2.5744, 5e-5);
  EXPECT_DOUBLE_EQ(r.equilibrium_overlap, 5e-5);
}

TEST(Calculator, CriticalVelocityAgainstDensityTable) {
  // Paper Fig. 3 and the sheet: eq. 21 to the digits shown.
  const double densities[] = {500, 1000, 2000, 3000, 4000, 5000, 6000, 7000, 8000};
  const double expected[] = {5.149, 3.641, 2.574, 2.102, 1.820, 1.628, 1.486, 1.376, 1.287};
  for (int k = 0; k < 9; ++k) {
    Case c = paper_case();
    c.materials[0].density = densities[k];
    const PairReport r = compute_pair_report(c, 0, 1e-3, 0, 1e-3, 1.0);
    EXPECT_NEAR(r.critical_velocity, expected[k], 5e-4) << "density " << densities[k];
  }
}

TEST(Calculator, StiffnessAndEquilibriumOverlapAreInverse) {
  Case c = paper_case();
  c.contact.bond.alpha = 0.7;
  c.normal_law = BondLawSpec{};
  c.contact.bond.input = AdhesionInput::kStiffness;
  c.contact.bond.stiffness = 3.0e3;
  const PairReport from_k = compute_pair_report(c, 0, 1e-3, 0, 2e-3, 1.0);
  c.contact.bond.input = AdhesionInput::kEquilibriumOverlap;
  c.contact.bond.equilibrium_overlap = from_k.equilibrium_overlap;
  const PairReport from_overlap = compute_pair_report(c, 0, 1e-3, 0, 2e-3, 1.0);
  EXPECT_NEAR(from_overlap.adhesion_stiffness, 3.0e3, 1e-9 * 3.0e3);
  // eq. 14 directly: delta_crit = (alpha k_adh / (2 E* sqrt r*))^(1/(3/2 - alpha)).
  const double direct =
      std::pow(0.7 * 3.0e3 / (2.0 * from_k.effective_modulus * std::sqrt(from_k.effective_radius)),
               1.0 / 0.8);
  EXPECT_NEAR(from_k.critical_overlap, direct, 1e-12 * direct);
  // k* vanishes at delta_crit (the inflection point of eq. 14).
  const double k_at_crit =
      2.0 * from_k.effective_modulus * std::sqrt(from_k.effective_radius * direct) -
      0.7 * 3.0e3 * std::pow(direct, -0.3);
  EXPECT_NEAR(k_at_crit, 0.0, 1e-9 * 2.0 * from_k.effective_modulus);
}

TEST(Calculator, CriticalVelocityReachesCriticalOverlap) {
  const PairReport r = compute_pair_report(paper_case(), 0, 1e-3, 0, 1e-3, 1.0);
  EXPECT_NEAR(hertz_max_overlap(r.effective_modulus, r.effective_radius, r.effective_mass,
                                r.critical_velocity),
              r.critical_overlap, 1e-12 * r.critical_overlap);
}

TEST(Calculator, TimeStepRuleAndWarnings) {
  const Case c = paper_case();
  const PairReport r = compute_pair_report(c, 0, 1e-3, 0, 1e-3, 2.6);
  // Hertz contact at 2.6 m/s lasts about 25 us; the paper's 0.5 us step resolves it in ~50 steps.
  EXPECT_NEAR(r.contact_time, 2.54e-5, 0.01e-5);
  EXPECT_DOUBLE_EQ(r.recommended_time_step,
                   std::min({r.contact_time / 50, r.bond_period / 50, 0.2 * r.rayleigh_time,
                             r.contact_damper_step, r.bond_damper_step}));
  EXPECT_TRUE(time_step_warnings(r, c.time_step).empty());
  const auto warnings = time_step_warnings(r, 2e-6);  // 13 steps per contact
  ASSERT_FALSE(warnings.empty());
  EXPECT_NE(warnings[0].find("recommended time step"), std::string::npos);
}

TEST(Calculator, DamperStepsEnterTheRuleAndTheWarnings) {
  Case c = paper_case();
  c.contact.damping_ratio = 1000.0;
  const PairReport r = compute_pair_report(c, 0, 1e-3, 0, 1e-3, 2.6);
  EXPECT_DOUBLE_EQ(r.contact_stiffness,
                   2.0 * r.effective_modulus * std::sqrt(r.effective_radius * r.max_overlap));
  EXPECT_DOUBLE_EQ(r.contact_damper_step,
                   damper_time_step(r.contact_stiffness, r.effective_mass, 1000.0));
  EXPECT_DOUBLE_EQ(r.recommended_time_step, r.contact_damper_step);
  const auto warnings = time_step_warnings(r, c.time_step);
  ASSERT_FALSE(warnings.empty());
  EXPECT_NE(warnings.back().find("contact damper"), std::string::npos) << warnings.back();
}

TEST(Calculator, NoBondingNoBondQuantitiesInTheRule) {
  Case c = paper_case();
  c.contact.bond.criterion = BondCriterion::kNever;
  c.contact.bond.damping_ratio = 1e6;  // would set the limit if a bond could form
  const PairReport r = compute_pair_report(c, 0, 1e-3, 0, 1e-3, 2.6);
  EXPECT_FALSE(r.bonding);
  EXPECT_EQ(r.bond_damper_step, std::numeric_limits<double>::infinity());
  EXPECT_DOUBLE_EQ(r.recommended_time_step,
                   std::min({r.contact_time / 50, 0.2 * r.rayleigh_time, r.contact_damper_step}));
}

TEST(Calculator, RejectsUnstableExponent) {
  Case c = paper_case();
  c.contact.bond.alpha = 1.5;
  c.normal_law = BondLawSpec{};
  EXPECT_THROW(compute_pair_report(c, 0, 1e-3, 0, 1e-3, 1.0), std::invalid_argument);
}

}  // namespace
}  // namespace bondem
