// The bond law at hand-computed points (values from the formulas of the equation sheet, evaluated
// independently in double precision), and each sign rule of Sec. 4.
#include <gtest/gtest.h>

#include "solver/models/bond_law.hpp"
#include "solver/models/pair.hpp"

namespace bondem {
namespace {

// The paper's pair: r = 1 mm, rho = 2000, E = 1 GPa, nu = 0 -> E* = 5e8 Pa, r* = 5e-4 m.
constexpr double kEStar = 5e8;
constexpr double kRStar = 5e-4;
constexpr double kMStar = 4.1887902047863905e-06;
// Only round-off separates the law from the hand evaluation.
constexpr double kRelTol = 1e-12;

BondPair paper_pair(double xi_con, double xi_bond) {
  const auto c = make_pair_coefficients(kEStar, xi_con, xi_bond, 1.0,
                                        AdhesionInput::kEquilibriumOverlap, 5e-5);
  return make_bond_pair(c, kRStar, kMStar);
}

TEST(BondLaw, PairCoefficientsMatchSheet) {
  const BondPair p = paper_pair(0.0, 0.5);
  EXPECT_NEAR(p.hertz_stiffness, 14907119.849998597, 1e-12 * 14907119.85);
  EXPECT_NEAR(p.adhesion_stiffness, 105409.25533894598, kRelTol * 105409.26);
  EXPECT_NEAR(p.critical_overlap, 2.222222222222222e-05, kRelTol * 2.2e-5);
  EXPECT_DOUBLE_EQ(p.equilibrium_overlap, 5e-5);
}

TEST(BondLaw, UndampedHertz) {
  const NormalForce f = normal_force(paper_pair(0.0, 0.5), LinearAdhesion{}, 1e-5, 0.3, false);
  EXPECT_NEAR(f.force, -0.47140452079103173, kRelTol * 0.47);
  EXPECT_FALSE(f.bonded);
}

TEST(BondLaw, DampedHertzEq26) {
  const NormalForce f = normal_force(paper_pair(0.3, 0.5), LinearAdhesion{}, 1e-5, 0.5, false);
  EXPECT_NEAR(f.force, -0.6346751477542127, kRelTol * 0.63);
}

TEST(BondLaw, BondBelowEquilibriumAttracts) {
  // delta_crit < 3e-5 < delta_eq, separating at 0.2 m/s: elastic and damping both attract.
  const NormalForce f = normal_force(paper_pair(0.3, 0.5), LinearAdhesion{}, 3e-5, -0.2, true);
  EXPECT_TRUE(f.bonded);
  EXPECT_NEAR(f.force, 0.7662604059403983, kRelTol);
}

TEST(BondLaw, BondAboveEquilibriumRepels) {
  const NormalForce f = normal_force(paper_pair(0.3, 0.5), LinearAdhesion{}, 7e-5, 0.1, true);
  EXPECT_TRUE(f.bonded);
  EXPECT_NEAR(f.force, -1.4103765095369198, kRelTol * 1.41);
}

TEST(BondLaw, GeneralAlphaMatchesHandValue) {
  // alpha = 0.5 with k_adh = 2000 N/m^0.5: delta_eq = k_adh / K = 1.3416e-4, delta_crit =
  // delta_eq/3.
  const auto c = make_pair_coefficients(kEStar, 0.0, 0.5, 0.5, AdhesionInput::kStiffness, 2.0e3);
  const BondPair p = make_bond_pair(c, kRStar, kMStar);
  EXPECT_NEAR(p.equilibrium_overlap, 0.00013416407864998739, kRelTol * 1.3e-4);
  EXPECT_NEAR(p.critical_overlap, 4.4721359549995795e-05, kRelTol * 4.5e-5);
  const NormalForce f = normal_force(p, GeneralAdhesion{0.5}, 8e-5, 0.05, true);
  EXPECT_TRUE(f.bonded);
  EXPECT_NEAR(f.force, 7.191486486224467, kRelTol * 7.2);
}

TEST(BondLaw, GeneralAdhesionAtAlphaOneEqualsLinear) {
  const BondPair p = paper_pair(0.2, 0.5);
  for (double overlap : {2.5e-5, 4e-5, 6e-5, 9e-5}) {
    for (double rate : {-0.3, 0.0, 0.3}) {
      EXPECT_NEAR(normal_force(p, GeneralAdhesion{1.0}, overlap, rate, true).force,
                  normal_force(p, LinearAdhesion{}, overlap, rate, true).force, 1e-12);
    }
  }
}

TEST(BondLaw, ZeroAlphaIsConstantAdhesion) {
  // alpha = 0: delta_crit = 0, the adhesive term is the constant k_adh.
  const auto c = make_pair_coefficients(kEStar, 0.0, 0.0, 0.0, AdhesionInput::kStiffness, 0.1);
  const BondPair p = make_bond_pair(c, kRStar, kMStar);
  EXPECT_EQ(p.critical_overlap, 0.0);
  const double overlap = 1e-7;
  const double expected = -p.hertz_stiffness * overlap * std::sqrt(overlap) + 0.1;
  EXPECT_NEAR(normal_force(p, GeneralAdhesion{0.0}, overlap, 0.0, true).force, expected, 1e-15);
}

// Sign rule 1: below delta_crit a damped contact never attracts.
TEST(BondLawSignRules, HertzNeverAttracts) {
  const BondPair p = paper_pair(0.5, 0.5);
  // Separating fast: -K d^1.5 - d_con * rate would be positive.
  EXPECT_EQ(normal_force(p, LinearAdhesion{}, 1e-5, -5.0, true).force, 0.0);
  EXPECT_LT(normal_force(p, LinearAdhesion{}, 1e-5, -0.01, true).force, 0.0);
}

// Sign rule 2: compressed bond (delta > delta_eq) never attracts.
TEST(BondLawSignRules, CompressedBondNeverAttracts) {
  const BondPair p = paper_pair(0.0, 1.0);
  const NormalForce f = normal_force(p, LinearAdhesion{}, 6e-5, -50.0, true);
  EXPECT_TRUE(f.bonded);
  EXPECT_EQ(f.force, 0.0);
  EXPECT_LT(normal_force(p, LinearAdhesion{}, 6e-5, -0.01, true).force, 0.0);
}

// Sign rule 3: stretched bond (delta_crit < delta < delta_eq) never repels.
TEST(BondLawSignRules, StretchedBondNeverRepels) {
  const BondPair p = paper_pair(0.0, 1.0);
  const NormalForce f = normal_force(p, LinearAdhesion{}, 4e-5, 50.0, true);
  EXPECT_TRUE(f.bonded);
  EXPECT_EQ(f.force, 0.0);
  EXPECT_GT(normal_force(p, LinearAdhesion{}, 4e-5, 0.01, true).force, 0.0);
}

TEST(BondLawCriterion, BondNeedsCriticalOverlapAndCriterion) {
  const BondPair p = paper_pair(0.0, 1.0);
  EXPECT_FALSE(normal_force(p, LinearAdhesion{}, 2.0e-5, 0.0, true).bonded);  // below delta_crit
  EXPECT_TRUE(normal_force(p, LinearAdhesion{}, 2.3e-5, 0.0, true).bonded);
  EXPECT_FALSE(normal_force(p, LinearAdhesion{}, 2.3e-5, 0.0, false).bonded);  // criterion fails
  // Without the criterion the same overlap is plain Hertz: repulsive.
  EXPECT_LT(normal_force(p, LinearAdhesion{}, 2.3e-5, 0.0, false).force, 0.0);
}

TEST(BondLawCriterion, CriterionKinds) {
  EXPECT_TRUE(criterion_holds(BondCriterion::kAlways, false));
  EXPECT_FALSE(criterion_holds(BondCriterion::kNever, true));
  EXPECT_TRUE(criterion_holds(BondCriterion::kPairFlag, true));
  EXPECT_FALSE(criterion_holds(BondCriterion::kPairFlag, false));
}

}  // namespace
}  // namespace bondem
