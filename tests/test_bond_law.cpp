// The bond law at hand-computed points (values from the formulas of the equation sheet, evaluated
// independently in double precision), and each sign rule of Sec. 4.
#include <gtest/gtest.h>

#include "solver/models/bond_law.hpp"
#include "solver/models/contact_point.hpp"
#include "solver/models/normal_laws.hpp"
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

// A bond limits friction by its Hertz part, not by the net force (zero at delta_eq); a contact by
// its repulsion, and never by an attraction.
TEST(BondLaw, FrictionLoadOfABondIsItsHertzPart) {
  const BondPair p = paper_pair(0.3, 0.5);
  const double overlap = p.equilibrium_overlap;
  const NormalForce bonded = normal_force(p, LinearAdhesion{}, overlap, 0.0, true);
  ASSERT_TRUE(bonded.bonded);
  EXPECT_NEAR(bonded.force, 0.0, 1e-9 * p.hertz_stiffness * std::pow(overlap, 1.5));
  EXPECT_DOUBLE_EQ(friction_load(p, bonded, overlap), p.hertz_stiffness * std::pow(overlap, 1.5));
  EXPECT_EQ(friction_load(p, NormalForce{-2.0, false}, overlap), 2.0);
  EXPECT_EQ(friction_load(p, NormalForce{0.5, false}, overlap), 0.0);
}

TEST(BondLaw, TemperatureCriterionKeepsASolidifiedBond) {
  EXPECT_TRUE(temperature_criterion(false, 1200.0, 1300.0, 1200.0));
  EXPECT_FALSE(temperature_criterion(false, 1199.0, 1300.0, 1200.0));
  EXPECT_TRUE(temperature_criterion(true, 300.0, 300.0, 1200.0));
}

// The law object the kernels call is the bond law itself, and its time scales are the calculator's
// Hertz impact.
TEST(BondLaw, RegisteredLawObjectIsTheBondLaw) {
  PairCoefficients c =
      make_pair_coefficients(1e9, 0.3, 0.5, 0.5, AdhesionInput::kEquilibriumOverlap, 2e-6);
  const NormalLawSpec spec = BondLawSpec{};  // alpha_adh is the pair's: 0.5
  const NormalForce f = with_normal_law(spec, [&](const auto& law) {
    return law.force(law.pair(c, kRStar, kMStar), 3e-6, 0.01, true);
  });
  const NormalForce expected =
      normal_force(make_bond_pair(c, kRStar, kMStar), GeneralAdhesion{0.5}, 3e-6, 0.01, true);
  EXPECT_EQ(f.force, expected.force);
  EXPECT_EQ(f.bonded, expected.bonded);
  const NormalTimeScales t = with_normal_law(
      spec, [&](const auto& law) { return law.time_scales(c, kRStar, kMStar, 1.0, false); });
  EXPECT_EQ(t.contact_time, hertz_contact_time(1e9, kRStar, kMStar, 1.0));
  EXPECT_TRUE(std::isinf(t.oscillation_period));
}

// Two spheres rolling on each other without slip: the contact points move together.
TEST(ContactPoint, RollingWithoutSlipHasNoContactVelocity) {
  const double r_i = 1e-3, r_j = 2e-3, overlap = 1e-5;
  const Eigen::Vector3d n(1.0, 0.0, 0.0);
  const Eigen::Vector3d lever_i = pair_lever(r_i, overlap) * n;
  const Eigen::Vector3d lever_j = -pair_lever(r_j, overlap) * n;
  EXPECT_DOUBLE_EQ((lever_j - lever_i).norm() + overlap, r_i + r_j);  // centre distance
  // i spins about z at w; j counter-spins so that its surface speed at the contact matches.
  const Eigen::Vector3d w_i(0.0, 0.0, 3.0);
  const Eigen::Vector3d w_j = -w_i * lever_i.norm() / lever_j.norm();
  const Eigen::Vector3d v = contact_velocity(Eigen::Vector3d::Zero(), w_i, lever_i,
                                             Eigen::Vector3d::Zero(), w_j, lever_j);
  EXPECT_LT(v.norm(), 1e-15);
  // The same spin on both slides at the contact: 3 (L_i + L_j) along y.
  const Eigen::Vector3d slide = contact_velocity(Eigen::Vector3d::Zero(), w_i, lever_i,
                                                 Eigen::Vector3d::Zero(), w_i, lever_j);
  EXPECT_NEAR(slide.y(), -3.0 * (lever_i.norm() + lever_j.norm()), 1e-15);
  // Each member's torque is its own lever length times n x F_t.
  const Eigen::Vector3d f_t(0.0, 2.0, 0.0);
  EXPECT_EQ(lever_torque(pair_lever(r_i, overlap), torque_per_lever(n, f_t)), moment(lever_i, f_t));
  EXPECT_EQ(lever_torque(pair_lever(r_j, overlap), torque_per_lever(n, f_t)),
            moment(lever_j, Eigen::Vector3d(-f_t)));
}

}  // namespace
}  // namespace bondem
