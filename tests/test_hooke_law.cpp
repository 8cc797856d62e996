// The linear spring-dashpot normal law ("hooke"): its force function, its law object, the time-step
// rule it feeds, and how the case reader accepts and refuses it.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <variant>

#include "case_text.hpp"
#include "hooke_case.hpp"
#include "io/case_file.hpp"
#include "io/checkpoint.hpp"
#include "solver/engine/scene.hpp"
#include "solver/experiments/calculator.hpp"
#include "solver/models/hooke_law.hpp"
#include "solver/models/normal_laws.hpp"

namespace bondem {
namespace {

using testing::error_of;
using testing::kHookeCase;
using testing::replace;

TEST(HookeLaw, ForceAtHandValues) {
  // k = 1e4 N/m, m* = 1e-4 kg, xi = 0.5: damping 2 * 0.5 * sqrt(1e-4 * 1e4) = 1 N s/m.
  const HookePair pair = make_hooke_pair(1.0e4, 1.0e-4, 0.5);
  EXPECT_DOUBLE_EQ(pair.stiffness, 1.0e4);
  EXPECT_DOUBLE_EQ(pair.damping, 1.0);
  EXPECT_DOUBLE_EQ(hooke_contact_force(pair, 1.0e-5, 0.0), -0.1);     // -k delta
  EXPECT_DOUBLE_EQ(hooke_contact_force(pair, 1.0e-5, 0.2), -0.3);     // approaching: more repulsion
  EXPECT_DOUBLE_EQ(hooke_contact_force(pair, 1.0e-5, -0.05), -0.05);  // separating: less
}

TEST(HookeLaw, NeverAttracts) {
  // Separating faster than k delta / c: the total would pull (+0.4 N); clamped to zero.
  const HookePair pair = make_hooke_pair(1.0e4, 1.0e-4, 0.5);
  EXPECT_EQ(hooke_contact_force(pair, 1.0e-5, -0.5), 0.0);
  EXPECT_EQ(hooke_contact_force(pair, 1.0e-5, -0.1), 0.0);  // exactly balanced: zero, not -0
  const HookeNormalLaw law{1.0e4};
  PairCoefficients c;
  c.contact_damping = 0.5;
  // A particle on a wall is the same law with m* = m: clamped just the same.
  EXPECT_EQ(law.force(law.pair(c, 1e-3, 1e-4), 1.0e-5, -0.5, false).force, 0.0);
}

TEST(HookeLaw, LawObjectNeverBondsAndCarriesItsLoad) {
  const HookeNormalLaw law{1.0e4};
  PairCoefficients c;
  c.contact_damping = 0.5;
  const HookePair pair = law.pair(c, 5e-4, 1.0e-4);
  EXPECT_DOUBLE_EQ(pair.damping, 1.0);
  // Whatever the criterion says, and however deep: no adhesive branch.
  const NormalForce deep = law.force(pair, 1.0e-3, 0.0, true);
  EXPECT_FALSE(deep.bonded);
  EXPECT_DOUBLE_EQ(deep.force, -10.0);
  EXPECT_DOUBLE_EQ(law.friction_load(pair, deep, 1.0e-3), 10.0);
  const NormalForce released = law.force(pair, 1.0e-5, -0.5, true);
  EXPECT_EQ(released.force, 0.0);
  EXPECT_EQ(law.friction_load(pair, released, 1.0e-5), 0.0);
}

TEST(HookeLaw, TimeScalesOfTheUndampedImpact) {
  const HookeNormalLaw law{1.0e4};
  PairCoefficients c;
  c.contact_damping = 0.3;
  const double m_star = 1.0e-4;
  const NormalTimeScales s = law.time_scales(c, 1e-3, m_star, 2.0, true);
  EXPECT_DOUBLE_EQ(s.contact_time, std::numbers::pi * 1.0e-4);  // pi sqrt(m*/k), any speed
  EXPECT_DOUBLE_EQ(law.time_scales(c, 1e-3, m_star, 7.0, true).contact_time, s.contact_time);
  EXPECT_DOUBLE_EQ(s.impact_overlap, 2.0e-4);  // v sqrt(m*/k)
  EXPECT_DOUBLE_EQ(s.contact_stiffness, 1.0e4);
  EXPECT_DOUBLE_EQ(s.contact_damping, 0.3);
  EXPECT_TRUE(std::isinf(s.oscillation_period));  // never bonds, even when asked about bonding
}

TEST(HookeLaw, ClampedRestitutionAndContactTime) {
  EXPECT_DOUBLE_EQ(hooke_restitution(0.0), 1.0);
  EXPECT_NEAR(hooke_contact_time(1.0e4, 1.0e-4, 0.0), std::numbers::pi * 1.0e-4, 1e-18);
  // The clamp ends the contact at zero force, before zero overlap: more rebound than the
  // attracting dashpot's exp(-pi xi / sqrt(1 - xi^2)) and a shorter contact than pi / omega_d.
  for (double xi : {0.1, 0.3, 0.6, 0.9}) {
    const double s = std::sqrt(1.0 - xi * xi);
    EXPECT_GT(hooke_restitution(xi), std::exp(-std::numbers::pi * xi / s)) << xi;
    EXPECT_LT(hooke_contact_time(1.0e4, 1.0e-4, xi), std::numbers::pi * 1.0e-4 / s) << xi;
  }
  // Hand value at xi = 0.3: theta = atan2(0.6 s, 0.82), e = exp(-0.3 / s (pi - theta)).
  const double s = std::sqrt(0.91);
  EXPECT_NEAR(hooke_restitution(0.3),
              std::exp(-0.3 / s * (std::numbers::pi - std::atan2(0.6 * s, 0.82))), 1e-15);
  EXPECT_NEAR(hooke_restitution(0.3), 0.4509, 1e-4);
}

TEST(HookeReader, AcceptsHookeWithStiffness) {
  const Case c = parse_case(kHookeCase, "case.yaml");
  ASSERT_TRUE(std::holds_alternative<HookeLawSpec>(c.normal_law));
  EXPECT_EQ(std::get<HookeLawSpec>(c.normal_law).stiffness, 1.0e4);
  EXPECT_EQ(c.contact.bond.criterion, BondCriterion::kNever);
  // hertz is the default, also when named.
  const Case hertz =
      parse_case(replace(replace(kHookeCase, "normal_law: hooke", "normal_law: hertz"),
                         "  stiffness: 1.0e4\n", ""),
                 "case.yaml");
  EXPECT_TRUE(std::holds_alternative<BondLawSpec>(hertz.normal_law));
}

TEST(HookeReader, RefusesBadInput) {
  EXPECT_NE(error_of(replace(kHookeCase, "normal_law: hooke", "normal_law: hook"))
                .find("'contact.normal_law': unknown normal law 'hook' (expected hertz or hooke)"),
            std::string::npos);
  EXPECT_NE(error_of(replace(kHookeCase, "  stiffness: 1.0e4\n", ""))
                .find("'contact.stiffness': missing required key"),
            std::string::npos);
  EXPECT_NE(
      error_of(replace(kHookeCase, "stiffness: 1.0e4", "stiffness: 0")).find("'contact.stiffness'"),
      std::string::npos);
  EXPECT_NE(error_of(replace(kHookeCase, "stiffness: 1.0e4", "stiffness: -1"))
                .find("'contact.stiffness'"),
            std::string::npos);
  EXPECT_NE(error_of(replace(kHookeCase, "stiffness: 1.0e4", "stiffness: soft"))
                .find("'contact.stiffness'"),
            std::string::npos);
  // A stiffness without hooke.
  EXPECT_NE(error_of(replace(kHookeCase, "  normal_law: hooke\n", ""))
                .find("'contact.stiffness': only with normal_law hooke"),
            std::string::npos);
  // No adhesion: a bond block is refused rather than ignored.
  EXPECT_NE(error_of(kHookeCase + "bond: {alpha: 1, equilibrium_overlap: 1.0e-5, damping_ratio: "
                                  "0.5, criterion: always}\n")
                .find("'bond': contact.normal_law hooke has no adhesion"),
            std::string::npos);
  // --set reaches the keys too.
  EXPECT_NE(error_of(kHookeCase, {"contact.stiffness=-5"}).find("'contact.stiffness'"),
            std::string::npos);
}

TEST(HookeReader, FingerprintCoversLawAndStiffness) {
  const Case c = parse_case(kHookeCase, "case.yaml");
  Case code_built = c;
  code_built.settings.clear();  // the Case fields alone must tell the stiffness apart
  Case stiffer = code_built;
  stiffer.normal_law = HookeLawSpec{2.0e4};
  EXPECT_NE(case_fingerprint(code_built), case_fingerprint(stiffer));
  EXPECT_NE(canonical_case_text(code_built).find("case.normal_law.stiffness="), std::string::npos);
  Case bond = code_built;
  bond.normal_law = BondLawSpec{};
  EXPECT_NE(case_fingerprint(code_built), case_fingerprint(bond));
}

TEST(HookeTimeStep, ContactTimeOverFiftySetsTheLimit) {
  const Case c = parse_case(kHookeCase, "case.yaml");
  const double m_star = 0.5 * 4.0 / 3.0 * std::numbers::pi * 1e-9 * 2000.0;
  const double t_c = std::numbers::pi * std::sqrt(m_star / 1.0e4);
  const TimeStepLimit limit = case_time_step_bound(c);
  EXPECT_NEAR(limit.step, t_c / kStepsPerOscillation, 1e-12 * t_c);
  EXPECT_NE(limit.cause.find("hooke"), std::string::npos) << limit.cause;
  // Four times stiffer: half the contact time, half the limit.
  const Case stiffer = parse_case(kHookeCase, "case.yaml", {"contact.stiffness=4.0e4"});
  EXPECT_NEAR(case_time_step_bound(stiffer).step, 0.5 * limit.step, 1e-12 * limit.step);
  const PairReport r = compute_pair_report(c, 0, 1e-3, 0, 1e-3, 1.0);
  EXPECT_NEAR(r.contact_time, t_c, 1e-12 * t_c);
  EXPECT_TRUE(std::isinf(r.bond_period));
}

}  // namespace
}  // namespace bondem
