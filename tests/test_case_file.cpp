// Case files: the shipped cases load, overrides work, and every kind of bad input is refused
// with a message that names where it is.
#include <gtest/gtest.h>

#include <string>

#include "io/case_file.hpp"

namespace bondem {
namespace {

const std::string kValid = R"(materials:
  powder: {density: 2000, youngs_modulus: 1.0e9, poisson_ratio: 0.0}
contact:
  damping_ratio: 0.1
bond:
  alpha: 1
  equilibrium_overlap: 5.0e-5
  damping_ratio: 0.5
  criterion: always
time: {step: 5.0e-7, end: 0.005}
particles:
  - {material: powder, radius: 0.001, position: [0, 0, 0], velocity: [1, 0, 0]}
  - {material: powder, radius: 0.001, position: [0.002, 0, 0]}
output:
  directory: out
)";

/// The CaseError message of parsing @p text with @p overrides ("" when it parses).
std::string error_of(const std::string& text, const std::vector<std::string>& overrides = {}) {
  try {
    parse_case(text, "case.yaml", overrides);
  } catch (const CaseError& e) {
    return e.what();
  }
  return "";
}

std::string replace(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

TEST(CaseFile, ValidCaseReadsEveryField) {
  const Case c = parse_case(kValid, "case.yaml");
  ASSERT_EQ(c.materials.size(), 1u);
  EXPECT_EQ(c.materials[0].name, "powder");
  EXPECT_DOUBLE_EQ(c.materials[0].youngs_modulus, 1e9);
  EXPECT_DOUBLE_EQ(c.contact_damping, 0.1);
  EXPECT_EQ(c.bond.input, AdhesionInput::kEquilibriumOverlap);
  EXPECT_DOUBLE_EQ(c.bond.equilibrium_overlap, 5e-5);
  EXPECT_EQ(c.bond.criterion, BondCriterion::kAlways);
  EXPECT_DOUBLE_EQ(c.time_step, 5e-7);
  ASSERT_EQ(c.particles.size(), 2u);
  EXPECT_DOUBLE_EQ(c.particles[0].velocity.x(), 1.0);
  EXPECT_DOUBLE_EQ(c.particles[1].velocity.x(), 0.0);  // velocity defaults to rest
  EXPECT_EQ(c.output_directory, "out");
}

TEST(CaseFile, ShippedCasesLoad) {
  for (const char* name :
       {"/paper_5_1.yaml", "/paper_5_2.yaml", "/powder_bed_packing.yaml",
        "/powder_bed_packing_ci.yaml", "/powder_spreading.yaml", "/powder_spreading_ci.yaml"}) {
    EXPECT_NO_THROW(load_case(std::string(BONDEM_CASES_DIR) + name)) << name;
  }
}

TEST(CaseFile, UnknownKeyNamesFileLineColumnAndKey) {
  const std::string e = error_of(replace(kValid, "  damping_ratio: 0.5", "  damping_rato: 0.5"));
  EXPECT_NE(e.find("case.yaml:8:3:"), std::string::npos) << e;
  EXPECT_NE(e.find("'bond.damping_rato'"), std::string::npos) << e;
  EXPECT_NE(e.find("unknown key"), std::string::npos) << e;
}

TEST(CaseFile, WrongTypeIsNamed) {
  const std::string e = error_of(replace(kValid, "density: 2000", "density: heavy"));
  EXPECT_NE(e.find("case.yaml:2:21:"), std::string::npos) << e;
  EXPECT_NE(e.find("'materials.powder.density'"), std::string::npos) << e;
  EXPECT_NE(e.find("expected a number"), std::string::npos) << e;
}

TEST(CaseFile, OutOfRangeValuesAreRefused) {
  EXPECT_NE(error_of(replace(kValid, "alpha: 1", "alpha: 1.5")).find("'bond.alpha': must lie in"),
            std::string::npos);
  EXPECT_NE(error_of(replace(kValid, "radius: 0.001, position: [0, 0, 0]",
                             "radius: -0.001, position: [0, 0, 0]"))
                .find("'particles.0.radius': must be positive"),
            std::string::npos);
  EXPECT_NE(error_of(replace(kValid, "poisson_ratio: 0.0", "poisson_ratio: 0.5")).find("(-1, 0.5)"),
            std::string::npos);
  EXPECT_NE(error_of(replace(kValid, "step: 5.0e-7", "step: .nan")).find("must be finite"),
            std::string::npos);
  EXPECT_NE(error_of(replace(kValid, "end: 0.005", "end: 1.0e-8")).find("shorter than one"),
            std::string::npos);
}

TEST(CaseFile, StructuralMistakes) {
  EXPECT_NE(error_of(replace(kValid, "  equilibrium_overlap: 5.0e-5",
                             "  equilibrium_overlap: 5.0e-5\n  stiffness: 1.0e5"))
                .find("not both"),
            std::string::npos);
  EXPECT_NE(
      error_of(replace(kValid, "  equilibrium_overlap: 5.0e-5\n", "")).find("needs bond.stiffness"),
      std::string::npos);
  EXPECT_NE(
      error_of(replace(kValid, "contact:\n  damping_ratio: 0.1\n", "")).find("'contact': missing"),
      std::string::npos);
  EXPECT_NE(error_of(replace(kValid, "material: powder, radius: 0.001, position: [0.002",
                             "material: steel, radius: 0.001, position: [0.002"))
                .find("no material named 'steel'"),
            std::string::npos);
  EXPECT_NE(error_of(replace(kValid, "position: [0, 0, 0]", "position: [0, 0]")).find("[x, y, z]"),
            std::string::npos);
  EXPECT_NE(error_of(replace(kValid, "criterion: always", "criterion: sometimes"))
                .find("unknown criterion"),
            std::string::npos);
  EXPECT_NE(error_of(replace(kValid, "time: {step: 5.0e-7, end: 0.005}",
                             "time: {step: 5.0e-7, end: 0.005, step: 1.0e-7}"))
                .find("given twice"),
            std::string::npos);
  EXPECT_NE(error_of("materials: [unclosed").find("case.yaml:1:"), std::string::npos);
  EXPECT_NE(error_of("").find("empty"), std::string::npos);
}

TEST(CaseFile, ParticlesMustFitDomainWallsAndEachOther) {
  const std::string boxed =
      kValid + R"(domain: {min: [-0.01, -0.01, -0.01], max: [0.01, 0.01, 0.01]}
walls:
  - {type: plane, point: [0, 0, -0.0005], normal: [0, 0, 1], material: powder, name: floor}
)";
  EXPECT_NE(error_of(boxed).find("overlaps wall 'floor'"), std::string::npos) << error_of(boxed);
  const std::string fixed = replace(boxed, "[0, 0, -0.0005]", "[0, 0, -0.001]");
  EXPECT_EQ(error_of(fixed), "");
  EXPECT_NE(error_of(fixed, {"particles.1.position.0=0.02"}).find("lies outside the domain"),
            std::string::npos);
  EXPECT_NE(error_of(fixed, {"particles.1.position.0=0.0019"}).find("overlaps particles.0"),
            std::string::npos);
  EXPECT_NE(error_of(fixed, {"domain.max.1=-0.02"}).find("must exceed min"), std::string::npos);
}

TEST(CaseFile, InsertionsAddParticlesAndReportFailures) {
  const std::string filled =
      kValid + R"(domain: {min: [-0.01, -0.01, -0.01], max: [0.01, 0.01, 0.01]}
insert:
  - {type: lattice, region: {min: [-0.01, -0.01, 0.004], max: [0.01, 0.01, 0.01]}, spacing: 0.002, radius: 0.0009, material: powder}
  - type: random
    region: {min: [-0.01, -0.01, -0.01], max: [0.01, 0.01, -0.002]}
    material: powder
    count: 200
    radius: {distribution: lognormal, median: 0.0003, sigma: 0.2, min: 0.0002, max: 0.0005}
    seed: 4
)";
  const Case c = parse_case(filled, "case.yaml");
  EXPECT_EQ(c.particles.size(), 2u + 10u * 10u * 3u + 200u);
  std::string e = error_of(filled, {"insert.1.count=100000"});
  EXPECT_NE(e.find("case.yaml:19:5: 'insert.1': random fill"), std::string::npos) << e;
  e = error_of(filled, {"insert.1.radius.sigma=-1"});
  EXPECT_NE(e.find("'insert.1.radius.sigma': must be positive"), std::string::npos) << e;
  e = error_of(filled, {"insert.0.type=hexagonal"});
  EXPECT_NE(e.find("unknown insertion 'hexagonal'"), std::string::npos) << e;
}

TEST(CaseFile, OverridesSetScalarsByDottedPath) {
  const Case c = parse_case(kValid, "case.yaml",
                            {"materials.powder.density=500", "particles.1.radius=0.002",
                             "particles.0.position.2=0.25", "bond.criterion=never"});
  EXPECT_DOUBLE_EQ(c.materials[0].density, 500.0);
  EXPECT_DOUBLE_EQ(c.particles[1].radius, 0.002);
  EXPECT_DOUBLE_EQ(c.particles[0].position.z(), 0.25);
  EXPECT_EQ(c.bond.criterion, BondCriterion::kNever);
}

TEST(CaseFile, OverridesAreValidatedLikeTheFile) {
  std::string e = error_of(kValid, {"materials.powder.density=-5"});
  EXPECT_NE(e.find("--set materials.powder.density=-5"), std::string::npos) << e;
  EXPECT_NE(e.find("must be positive"), std::string::npos) << e;
  e = error_of(kValid, {"bond.stifness=3"});
  EXPECT_NE(e.find("unknown key"), std::string::npos) << e;
  e = error_of(kValid, {"particles.7.radius=1"});
  EXPECT_NE(e.find("not an index of a list of 2"), std::string::npos) << e;
  e = error_of(kValid, {"materials.powder=3"});
  EXPECT_NE(e.find("not a single value"), std::string::npos) << e;
  e = error_of(kValid, {"nokey.at.all=1"});
  EXPECT_NE(e.find("no key 'nokey'"), std::string::npos) << e;
  e = error_of(kValid, {"density"});
  EXPECT_NE(e.find("KEY=VALUE"), std::string::npos) << e;
}

}  // namespace
}  // namespace bondem
