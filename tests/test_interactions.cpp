// The contact model per pair of materials as the reader builds it: the `contact:` defaults, the
// `interactions:` overrides, restitution as an input, and every kind of bad input refused with
// the key named.
#include <gtest/gtest.h>

#include <string>

#include "case_text.hpp"
#include "io/case_file.hpp"
#include "io/checkpoint.hpp"
#include "solver/models/restitution.hpp"

namespace bondem {
namespace {

using testing::error_of;
using testing::replace;

/// Powder on a steel floor: defaults for powder-powder, an override for powder-steel.
const std::string kTwoMaterials = R"(materials:
  powder: {density: 2500, youngs_modulus: 1.0e7, poisson_ratio: 0.3}
  steel: {density: 7800, youngs_modulus: 2.0e7, poisson_ratio: 0.3}
contact:
  restitution: 0.5
  friction: 0.5
  rolling_friction: 0.1
  rolling_model: epsd
  rolling_damping: 0.2
  cohesion: {model: sjkr, energy_density: 1000}
bond:
  alpha: 1
  equilibrium_overlap: 1.0e-6
  damping_ratio: 1.0
  criterion: always
interactions:
  - materials: [powder, steel]
    friction: 0.3
    damping_ratio: 0.05
    cohesion: {model: none}
    bond: {criterion: never}
time: {step: 1.0e-7, end: 1.0e-5}
walls:
  - {type: plane, point: [0, 0, 0], normal: [0, 0, 1], material: steel, name: floor}
particles:
  - {material: powder, radius: 1.0e-4, position: [0, 0, 2.0e-4]}
  - {material: powder, radius: 1.0e-4, position: [3.0e-4, 0, 2.0e-4]}
)";

TEST(Interactions, OverrideAppliesToItsPairOnlyAndOverTheDefaults) {
  const Case c = parse_case(kTwoMaterials, "case.yaml");
  ASSERT_EQ(c.interactions.size(), 1u);
  // powder-powder: the defaults, restitution derived into the damping ratio.
  const PairCoefficients powder = c.pair_coefficients(0, 0);
  EXPECT_EQ(powder.restitution, 0.5);
  EXPECT_EQ(powder.contact_damping, hertz_damping_ratio(0.5));
  EXPECT_EQ(powder.friction, 0.5);
  EXPECT_EQ(powder.rolling_model, RollingModel::kEpsd);
  EXPECT_EQ(powder.rolling_damping, 0.2);
  EXPECT_EQ(powder.cohesion, CohesionModel::kSjkr);
  EXPECT_EQ(powder.cohesion_energy, 1000.0);
  EXPECT_EQ(powder.criterion, BondCriterion::kAlways);
  // powder-steel, either way round: the keys given override, the others are the defaults'.
  for (const auto& [a, b] : {std::pair{0, 1}, std::pair{1, 0}}) {
    const PairCoefficients wall = c.pair_coefficients(a, b);
    EXPECT_EQ(wall.friction, 0.3);
    EXPECT_EQ(wall.contact_damping, 0.05);  // damping_ratio replaces the default restitution
    EXPECT_EQ(wall.restitution, 0.0);
    EXPECT_EQ(wall.rolling_friction, 0.1);
    EXPECT_EQ(wall.rolling_model, RollingModel::kEpsd);
    EXPECT_EQ(wall.cohesion, CohesionModel::kNone);
    EXPECT_EQ(wall.criterion, BondCriterion::kNever);
    EXPECT_EQ(wall.bond_damping, 1.0);  // bond keys not given stay the defaults'
  }
  // steel-steel has no entry: the defaults.
  EXPECT_EQ(c.pair_coefficients(1, 1).friction, 0.5);
}

TEST(Interactions, SetReachesInteractionKeysAndTheFingerprintSeesThem) {
  const Case base = parse_case(kTwoMaterials, "case.yaml");
  const Case changed = parse_case(kTwoMaterials, "case.yaml", {"interactions.0.friction=0.25"});
  EXPECT_EQ(changed.pair_coefficients(0, 1).friction, 0.25);
  EXPECT_NE(case_fingerprint(base), case_fingerprint(changed));
  const Case cohesive =
      parse_case(kTwoMaterials, "case.yaml", {"contact.cohesion.energy_density=2000"});
  EXPECT_EQ(cohesive.pair_coefficients(0, 0).cohesion_energy, 2000.0);
  EXPECT_NE(case_fingerprint(base), case_fingerprint(cohesive));
}

TEST(Interactions, RestitutionMapsThroughTheRunsNormalLaw) {
  const std::string hooke =
      replace(kTwoMaterials, "contact:\n", "contact:\n  normal_law: hooke\n  stiffness: 1.0e3\n");
  const std::string no_bond = replace(
      hooke,
      "bond:\n  alpha: 1\n  equilibrium_overlap: 1.0e-6\n  damping_ratio: 1.0\n  criterion: "
      "always\n",
      "");
  const Case c = parse_case(replace(no_bond, "    bond: {criterion: never}\n", ""), "case.yaml");
  EXPECT_EQ(c.pair_coefficients(0, 0).contact_damping, hooke_damping_ratio(0.5));
  // Below exp(-2) the clamped linear law is overdamped, and still reaches e.
  const Case low = parse_case(replace(no_bond, "    bond: {criterion: never}\n", ""), "case.yaml",
                              {"contact.restitution=0.05"});
  EXPECT_GT(low.pair_coefficients(0, 0).contact_damping, 1.0);
  EXPECT_NEAR(clamped_linear_restitution(low.pair_coefficients(0, 0).contact_damping), 0.05, 1e-12);
}

TEST(Interactions, BadInputIsRefusedWithTheKeyNamed) {
  // Unknown material, a pair given twice (also reversed), both damping inputs, neither.
  EXPECT_NE(error_of(replace(kTwoMaterials, "[powder, steel]", "[powder, stele]"))
                .find("'interactions.0.materials.1': no material named 'stele'"),
            std::string::npos);
  const std::string twice =
      replace(kTwoMaterials, "time: {", "  - {materials: [steel, powder], friction: 0.2}\ntime: {");
  EXPECT_NE(
      error_of(twice).find("'interactions.1.materials': this pair of materials is given twice"),
      std::string::npos);
  EXPECT_NE(error_of(replace(kTwoMaterials, "  restitution: 0.5\n",
                             "  restitution: 0.5\n  damping_ratio: 0.1\n"))
                .find("'contact.damping_ratio': give either restitution or damping_ratio"),
            std::string::npos);
  EXPECT_NE(error_of(replace(kTwoMaterials, "    damping_ratio: 0.05\n",
                             "    damping_ratio: 0.05\n    restitution: 0.9\n"))
                .find("'interactions.0.damping_ratio': give either restitution or damping_ratio"),
            std::string::npos);
  EXPECT_NE(error_of(replace(kTwoMaterials, "  restitution: 0.5\n", ""))
                .find("'contact.restitution': missing required key"),
            std::string::npos);
  EXPECT_NE(error_of(replace(kTwoMaterials, "restitution: 0.5", "restitution: 1.5"))
                .find("'contact.restitution': must lie in (0, 1]"),
            std::string::npos);
  // Cohesion: unknown model, a parameter of the other model, jkr on the linear law.
  EXPECT_NE(error_of(replace(kTwoMaterials, "model: sjkr", "model: dmt"))
                .find("'contact.cohesion.model': unknown cohesion model 'dmt'"),
            std::string::npos);
  EXPECT_NE(
      error_of(replace(kTwoMaterials, "model: sjkr, energy_density", "model: jkr, energy_density"))
          .find("'contact.cohesion.energy_density': does not belong to cohesion model jkr"),
      std::string::npos);
  // Rolling: unknown model; a damper for the model that has none.
  EXPECT_NE(error_of(replace(kTwoMaterials, "rolling_model: epsd", "rolling_model: viscous"))
                .find("'contact.rolling_model': unknown rolling model 'viscous'"),
            std::string::npos);
  EXPECT_NE(
      error_of(replace(kTwoMaterials, "rolling_model: epsd", "rolling_model: constant_torque"))
          .find("'contact.rolling_damping': only with rolling_model epsd"),
      std::string::npos);
  // An unknown key in an entry, and the run-wide law where only pair keys belong.
  EXPECT_NE(error_of(replace(kTwoMaterials, "    friction: 0.3\n", "    fricton: 0.3\n"))
                .find("'interactions.0.fricton': unknown key"),
            std::string::npos);
  EXPECT_NE(error_of(replace(kTwoMaterials, "    friction: 0.3\n", "    normal_law: hooke\n"))
                .find("'interactions.0.normal_law': unknown key"),
            std::string::npos);
}

TEST(Interactions, JkrAndBondsNeedTheHertzLaw) {
  const std::string hooke = replace(
      replace(kTwoMaterials, "contact:\n", "contact:\n  normal_law: hooke\n  stiffness: 1.0e3\n"),
      "bond:\n  alpha: 1\n  equilibrium_overlap: 1.0e-6\n  damping_ratio: 1.0\n  criterion: "
      "always\n",
      "");
  // The linear law has no adhesion: an entry's bond block is refused as the top-level one is.
  EXPECT_NE(error_of(hooke).find("'interactions.0.bond': contact.normal_law hooke has no adhesion"),
            std::string::npos);
  const std::string e =
      error_of(replace(replace(hooke, "    bond: {criterion: never}\n", ""),
                       "{model: sjkr, energy_density: 1000}", "{model: jkr, surface_energy: 0.1}"));
  EXPECT_NE(e.find("'contact.cohesion.model': jkr is a Hertz-based theory"), std::string::npos)
      << e;
}

TEST(Interactions, BondOverrideWithoutDefaultBondMustBeComplete) {
  const std::string no_default = replace(
      kTwoMaterials,
      "bond:\n  alpha: 1\n  equilibrium_overlap: 1.0e-6\n  damping_ratio: 1.0\n  criterion: "
      "always\n",
      "");
  // Only a criterion: alpha, the strength and the damper are missing.
  EXPECT_NE(error_of(replace(no_default, "bond: {criterion: never}", "bond: {criterion: always}"))
                .find("'interactions.0.bond.alpha': missing required key"),
            std::string::npos);
  const Case c = parse_case(
      replace(
          no_default, "bond: {criterion: never}",
          "bond: {alpha: 1, equilibrium_overlap: 2.0e-6, damping_ratio: 0.5, criterion: always}"),
      "case.yaml");
  EXPECT_EQ(c.pair_coefficients(0, 1).criterion, BondCriterion::kAlways);
  EXPECT_EQ(c.pair_coefficients(0, 1).equilibrium_overlap, 2.0e-6);
  EXPECT_EQ(c.pair_coefficients(0, 0).criterion, BondCriterion::kNever);
}

}  // namespace
}  // namespace bondem
