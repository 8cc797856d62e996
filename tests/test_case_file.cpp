// Case files: the shipped cases load, overrides work, and every kind of bad input is refused
// with a message that names where it is.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

#include "case_text.hpp"
#include "io/case_file.hpp"
#include "io/checkpoint.hpp"

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

/// A thermal case using every new key; line numbers below refer to it.
const std::string kThermal = R"(materials:
  ti64:
    density: 4430
    youngs_modulus: 1.0e7
    poisson_ratio: 0.34
    specific_heat: 560
    thermal_conductivity: 7.0
    emissivity: 0.4
  steel: {density: 7800, youngs_modulus: 2.0e11, poisson_ratio: 0.3, thermal_conductivity: 16}
contact:
  damping_ratio: 0.1
bond:
  alpha: 1
  equilibrium_overlap: 1.0e-6
  damping_ratio: 0.5
  criterion: temperature
  temperature: 1900
thermal:
  initial_temperature: 300
  ambient_temperature: 310
  convection_coefficient: 10
  radiation: true
laser:
  power: 100
  spot_radius: 5.0e-5
  absorptivity: 0.5
  start_time: 1.0e-4
  path:
    - {from: [0.0, 0.001], to: [0.004, 0.001], speed: 0.5}
    - {from: [0.004, 0.002], to: [0.0, 0.002], speed: 0.25}
time: {step: 1.0e-8, end: 1.0e-3}
walls:
  - {type: plane, point: [0, 0, 0], normal: [0, 0, 1], material: steel, name: plate}
  - {type: box, min: [-0.001, -0.001, -0.001], max: [0.005, 0.005, 0.005], material: steel, open: [z_max, z_min], temperature: 350}
particles:
  - {material: ti64, radius: 2.0e-5, position: [0.001, 0.001, 2.0e-5], temperature: 1000}
  - {material: ti64, radius: 2.0e-5, position: [0.002, 0.001, 2.0e-5]}
insert:
  - {type: lattice, region: {min: [0, 0, 0.0001], max: [0.0004, 0.0004, 0.0002]}, spacing: 0.0001, radius: 4.0e-5, material: ti64, temperature: 400}
  - {type: lattice, region: {min: [0.003, 0, 0.0001], max: [0.0034, 0.0004, 0.0002]}, spacing: 0.0001, radius: 4.0e-5, material: ti64}
)";

using testing::error_of;
using testing::replace;

TEST(CaseFile, ValidCaseReadsEveryField) {
  const Case c = parse_case(kValid, "case.yaml");
  ASSERT_EQ(c.materials.size(), 1u);
  EXPECT_EQ(c.materials[0].name, "powder");
  EXPECT_DOUBLE_EQ(c.materials[0].youngs_modulus, 1e9);
  EXPECT_DOUBLE_EQ(c.contact.damping_ratio, 0.1);
  EXPECT_EQ(c.contact.bond.input, AdhesionInput::kEquilibriumOverlap);
  EXPECT_DOUBLE_EQ(c.contact.bond.equilibrium_overlap, 5e-5);
  EXPECT_EQ(c.contact.bond.criterion, BondCriterion::kAlways);
  EXPECT_DOUBLE_EQ(c.time_step, 5e-7);
  ASSERT_EQ(c.particles.size(), 2u);
  EXPECT_DOUBLE_EQ(c.particles[0].velocity.x(), 1.0);
  EXPECT_DOUBLE_EQ(c.particles[1].velocity.x(), 0.0);  // velocity defaults to rest
  EXPECT_EQ(c.output_directory, "out");
}

TEST(CaseFile, ShippedCasesLoad) {
  for (const char* name :
       {"/paper_5_1.yaml", "/paper_5_2.yaml", "/powder_bed_packing.yaml",
        "/powder_bed_packing_ci.yaml", "/powder_spreading.yaml", "/powder_spreading_ci.yaml",
        "/powder_spreading_friction_ci.yaml", "/powder_spreading_cohesive_ci.yaml",
        "/laser_sintering.yaml", "/laser_sintering_ci.yaml", "/bench/peer_lattice.yaml"}) {
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
  // Half a radius of overlap: above the run's limit (limits.max_overlap_fraction, 0.25).
  EXPECT_NE(error_of(fixed, {"particles.1.position.0=0.0015"}).find("overlaps particles.0"),
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
  EXPECT_NE(e.find("--set insert.1.count=100000: 'insert.1': random fill"), std::string::npos) << e;
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
  EXPECT_EQ(c.contact.bond.criterion, BondCriterion::kNever);
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

TEST(CaseFile, ThermalCaseReadsEveryField) {
  const Case c = parse_case(kThermal, "case.yaml");
  ASSERT_EQ(c.materials.size(), 2u);
  EXPECT_DOUBLE_EQ(c.materials[0].specific_heat, 560.0);
  EXPECT_DOUBLE_EQ(c.materials[0].thermal_conductivity, 7.0);
  EXPECT_DOUBLE_EQ(c.materials[0].emissivity, 0.4);
  EXPECT_DOUBLE_EQ(c.materials[1].specific_heat, 0.0);  // walls only: no c_p needed
  EXPECT_DOUBLE_EQ(c.materials[1].thermal_conductivity, 16.0);
  EXPECT_DOUBLE_EQ(c.materials[1].emissivity, 0.0);  // default

  EXPECT_EQ(c.contact.bond.criterion, BondCriterion::kTemperature);
  EXPECT_DOUBLE_EQ(c.contact.bond.temperature, 1900.0);

  ASSERT_TRUE(c.thermal.has_value());
  EXPECT_DOUBLE_EQ(c.thermal->initial_temperature, 300.0);
  EXPECT_DOUBLE_EQ(c.thermal->ambient_temperature, 310.0);
  EXPECT_DOUBLE_EQ(c.thermal->convection_coefficient, 10.0);
  EXPECT_TRUE(c.thermal->radiation);

  ASSERT_TRUE(c.laser.has_value());
  EXPECT_DOUBLE_EQ(c.laser->power, 100.0);
  EXPECT_DOUBLE_EQ(c.laser->spot_radius, 5e-5);
  EXPECT_DOUBLE_EQ(c.laser->absorptivity, 0.5);
  EXPECT_DOUBLE_EQ(c.laser->start_time, 1e-4);
  ASSERT_EQ(c.laser->path.size(), 2u);
  EXPECT_EQ(c.laser->path[0].start, Eigen::Vector2d(0.0, 0.001));
  EXPECT_EQ(c.laser->path[0].end, Eigen::Vector2d(0.004, 0.001));
  EXPECT_DOUBLE_EQ(c.laser->path[0].speed, 0.5);
  EXPECT_EQ(c.laser->path[1].start, Eigen::Vector2d(0.004, 0.002));
  EXPECT_EQ(c.laser->path[1].end, Eigen::Vector2d(0.0, 0.002));
  EXPECT_DOUBLE_EQ(c.laser->path[1].speed, 0.25);

  ASSERT_EQ(c.boundaries.size(), 1u + 4u);  // the plane and the box without its z faces
  EXPECT_EQ(c.boundaries[0].name, "plate");
  EXPECT_DOUBLE_EQ(c.boundaries[0].temperature, 0.0);  // no temperature: adiabatic
  for (std::size_t k = 1; k < c.boundaries.size(); ++k) {
    EXPECT_DOUBLE_EQ(c.boundaries[k].temperature, 350.0) << c.boundaries[k].name;
  }

  // Explicit particles first, then each insertion in order.
  ASSERT_GT(c.particles.size(), 2u);
  EXPECT_DOUBLE_EQ(c.particles[0].temperature, 1000.0);  // its own
  EXPECT_DOUBLE_EQ(c.particles[1].temperature, 300.0);   // thermal.initial_temperature
  const std::size_t per_lattice = (c.particles.size() - 2) / 2;
  ASSERT_GT(per_lattice, 0u);
  ASSERT_EQ(c.particles.size(), 2 + 2 * per_lattice);
  for (std::size_t k = 2; k < 2 + per_lattice; ++k) {
    EXPECT_DOUBLE_EQ(c.particles[k].temperature, 400.0) << k;  // insert.0.temperature
  }
  for (std::size_t k = 2 + per_lattice; k < c.particles.size(); ++k) {
    EXPECT_DOUBLE_EQ(c.particles[k].temperature, 300.0) << k;
  }
}

TEST(CaseFile, ThermalDefaultsAndNoThermal) {
  // Without a thermal block nothing thermal is set and particles keep the struct default.
  const Case plain = parse_case(kValid, "case.yaml");
  EXPECT_FALSE(plain.thermal.has_value());
  EXPECT_FALSE(plain.laser.has_value());
  EXPECT_DOUBLE_EQ(plain.particles[0].temperature, ParticleSpec{}.temperature);
  // Thermal properties may sit in a material list without a thermal block.
  EXPECT_EQ(error_of(replace(kValid, "poisson_ratio: 0.0}", "poisson_ratio: 0.0, emissivity: 1}")),
            "");

  // An empty thermal block turns temperatures on with every default.
  const std::string on =
      replace(replace(kValid, "poisson_ratio: 0.0}", "poisson_ratio: 0.0, specific_heat: 800}"),
              "output:", "thermal: {}\noutput:");
  const Case c = parse_case(on, "case.yaml");
  ASSERT_TRUE(c.thermal.has_value());
  EXPECT_DOUBLE_EQ(c.thermal->initial_temperature, 293.15);
  EXPECT_DOUBLE_EQ(c.thermal->ambient_temperature, 293.15);
  EXPECT_DOUBLE_EQ(c.thermal->convection_coefficient, 0.0);
  EXPECT_FALSE(c.thermal->radiation);
  EXPECT_FALSE(c.laser.has_value());
  EXPECT_DOUBLE_EQ(c.materials[0].thermal_conductivity, 0.0);
  EXPECT_DOUBLE_EQ(c.particles[1].temperature, 293.15);
  EXPECT_EQ(c.contact.bond.criterion, BondCriterion::kAlways);
}

TEST(CaseFile, BondTemperatureGoesWithCriterionTemperature) {
  std::string e = error_of(replace(kThermal, "  temperature: 1900\n", ""));
  EXPECT_NE(e.find("case.yaml:13:3: 'bond.temperature': missing required key"), std::string::npos)
      << e;
  e = error_of(replace(kThermal, "criterion: temperature", "criterion: always"));
  EXPECT_NE(e.find("case.yaml:17:16: 'bond.temperature': only with criterion temperature"),
            std::string::npos)
      << e;
  e = error_of(replace(kThermal, "  temperature: 1900", "  temperature: -5"));
  EXPECT_NE(e.find("case.yaml:17:16: 'bond.temperature': must be positive"), std::string::npos)
      << e;
  e = error_of(replace(kValid, "criterion: always", "criterion: temperature\n  temperature: 1900"));
  EXPECT_NE(e.find("case.yaml:9:14: 'bond.criterion': needs a thermal: block"), std::string::npos)
      << e;
}

TEST(CaseFile, ThermalOnlyKeysNeedAThermalBlock) {
  const std::string cold = replace(kThermal,
                                   "thermal:\n  initial_temperature: 300\n  ambient_temperature: "
                                   "310\n  convection_coefficient: 10\n  radiation: true\n",
                                   "");
  std::string e = error_of(cold);
  EXPECT_NE(e.find("case.yaml:19:3: 'laser': needs a thermal: block"), std::string::npos) << e;
  const std::size_t laser_at = kThermal.find("laser:\n");
  const std::string no_laser =
      replace(cold, kThermal.substr(laser_at, kThermal.find("time: {") - laser_at), "");
  e = error_of(no_laser);
  EXPECT_NE(e.find("'bond.criterion': needs a thermal: block"), std::string::npos) << e;
  const std::string no_bond =
      replace(no_laser, "criterion: temperature\n  temperature: 1900", "criterion: always");
  e = error_of(no_bond);
  EXPECT_NE(e.find("'particles.0.temperature': needs a thermal: block"), std::string::npos) << e;
  const std::string no_particle = replace(no_bond, ", temperature: 1000}", "}");
  e = error_of(no_particle);
  EXPECT_NE(e.find("'walls.1.temperature': needs a thermal: block"), std::string::npos) << e;
  const std::string no_wall = replace(no_particle, ", temperature: 350}", "}");
  e = error_of(no_wall);
  EXPECT_NE(e.find("'insert.0.temperature': needs a thermal: block"), std::string::npos) << e;
  const std::string none = replace(no_wall, ", temperature: 400}", "}");
  EXPECT_EQ(error_of(none), "");  // the rest (material properties) is fine without thermal
}

TEST(CaseFile, LaserIsValidated) {
  std::string e = error_of(replace(kThermal, "absorptivity: 0.5", "absorptivity: 1.5"));
  EXPECT_NE(e.find("case.yaml:26:17: 'laser.absorptivity': must lie in [0, 1], got 1.5"),
            std::string::npos)
      << e;
  e = error_of(replace(kThermal,
                       "  path:\n    - {from: [0.0, 0.001], to: [0.004, 0.001], speed: 0.5}\n"
                       "    - {from: [0.004, 0.002], to: [0.0, 0.002], speed: 0.25}\n",
                       "  path: []\n"));
  EXPECT_NE(e.find("case.yaml:28:9: 'laser.path': needs at least one segment"), std::string::npos)
      << e;
  e = error_of(replace(kThermal, "speed: 0.25", "speed: 0"));
  EXPECT_NE(e.find("case.yaml:30:55: 'laser.path.1.speed': must be positive, got 0"),
            std::string::npos)
      << e;
  e = error_of(replace(kThermal, "  power: 100", "  powr: 100"));
  EXPECT_NE(e.find("case.yaml:24:3: 'laser.powr': unknown key (expected one of: power,"),
            std::string::npos)
      << e;
  e = error_of(replace(kThermal, "spot_radius: 5.0e-5", "spot_radius: 0"));
  EXPECT_NE(e.find("'laser.spot_radius': must be positive"), std::string::npos) << e;
  e = error_of(replace(kThermal, "power: 100", "power: -1"));
  EXPECT_NE(e.find("'laser.power': must not be negative"), std::string::npos) << e;
  e = error_of(replace(kThermal, "to: [0.0, 0.002]", "to: [0.0, 0.002, 0.0]"));
  EXPECT_NE(e.find("'laser.path.1.to': expected a list [x, y]"), std::string::npos) << e;
  e = error_of(replace(kThermal, "speed: 0.5}", "speed: 0.5, power: 3}"));
  EXPECT_NE(e.find("'laser.path.0.power': unknown key"), std::string::npos) << e;
  e = error_of(replace(kThermal, "  power: 100\n", ""));
  EXPECT_NE(e.find("'laser.power': missing required key"), std::string::npos) << e;
}

TEST(CaseFile, ThermalValuesAreRangeChecked) {
  std::string e = error_of(replace(kThermal, "emissivity: 0.4", "emissivity: 1.2"));
  EXPECT_NE(e.find("case.yaml:8:17: 'materials.ti64.emissivity': must lie in [0, 1]"),
            std::string::npos)
      << e;
  e = error_of(replace(kThermal, "specific_heat: 560", "specific_heat: 0"));
  EXPECT_NE(e.find("'materials.ti64.specific_heat': must be positive"), std::string::npos) << e;
  e = error_of(replace(kThermal, "thermal_conductivity: 16", "thermal_conductivity: -1"));
  EXPECT_NE(e.find("'materials.steel.thermal_conductivity': must not be negative"),
            std::string::npos)
      << e;
  e = error_of(replace(kThermal, "initial_temperature: 300", "initial_temperature: 0"));
  EXPECT_NE(e.find("case.yaml:19:24: 'thermal.initial_temperature': must be positive"),
            std::string::npos)
      << e;
  e = error_of(replace(kThermal, "convection_coefficient: 10", "convection_coefficient: -10"));
  EXPECT_NE(e.find("'thermal.convection_coefficient': must not be negative"), std::string::npos)
      << e;
  e = error_of(replace(kThermal, "radiation: true", "radiation: sometimes"));
  EXPECT_NE(e.find("'thermal.radiation': expected true or false"), std::string::npos) << e;
  e = error_of(replace(kThermal, "radiation: true", "radiaton: true"));
  EXPECT_NE(e.find("'thermal.radiaton': unknown key"), std::string::npos) << e;
  e = error_of(replace(kThermal, "temperature: 1000}", "temperature: -1000}"));
  EXPECT_NE(e.find("'particles.0.temperature': must be positive"), std::string::npos) << e;
  e = error_of(replace(kThermal, "temperature: 350}", "temperature: 0}"));
  EXPECT_NE(e.find("'walls.1.temperature': must be positive"), std::string::npos) << e;
}

TEST(CaseFile, ThermalNeedsSpecificHeatOfParticleMaterials) {
  const std::string e = error_of(replace(kThermal, "    specific_heat: 560\n", ""));
  EXPECT_NE(e.find("case.yaml:3:5: 'materials.ti64.specific_heat': missing required key"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("material 'ti64'"), std::string::npos) << e;
}

TEST(CaseFile, OverridesReachThermalKeys) {
  const Case c = parse_case(kThermal, "case.yaml",
                            {"laser.power=50", "laser.path.1.speed=2", "thermal.radiation=false",
                             "materials.ti64.emissivity=0.9", "particles.1.temperature=500"});
  EXPECT_DOUBLE_EQ(c.laser->power, 50.0);
  EXPECT_DOUBLE_EQ(c.laser->path[1].speed, 2.0);
  EXPECT_FALSE(c.thermal->radiation);
  EXPECT_DOUBLE_EQ(c.materials[0].emissivity, 0.9);
  EXPECT_DOUBLE_EQ(c.particles[1].temperature, 500.0);
  std::string e = error_of(kThermal, {"laser.absorptivity=2"});
  EXPECT_NE(e.find("--set laser.absorptivity=2: 'laser.absorptivity': must lie in [0, 1]"),
            std::string::npos)
      << e;
  e = error_of(kValid, {"bond.criterion=temperature"});
  EXPECT_NE(e.find("--set bond.criterion=temperature: 'bond.criterion': needs a thermal: block"),
            std::string::npos)
      << e;
}

TEST(CaseFile, CheckpointFingerprintCoversThermalSettings) {
  const std::uint64_t base = case_fingerprint(parse_case(kThermal, "case.yaml"));
  EXPECT_EQ(base, case_fingerprint(parse_case(kThermal, "case.yaml")));
  for (const char* change :
       {"laser.power=50", "laser.spot_radius=6.0e-5", "laser.absorptivity=0.6",
        "laser.start_time=0", "laser.path.0.to.0=0.003", "laser.path.1.speed=0.3",
        "thermal.ambient_temperature=300", "thermal.convection_coefficient=5",
        "thermal.radiation=false", "thermal.initial_temperature=310", "bond.temperature=1800",
        "materials.ti64.specific_heat=600", "materials.ti64.thermal_conductivity=8",
        "materials.steel.emissivity=0.2", "walls.1.temperature=360"}) {
    EXPECT_NE(base, case_fingerprint(parse_case(kThermal, "case.yaml", {change}))) << change;
  }
}

TEST(CaseFile, LimitsBlockIsRead) {
  // The documented `limits:` block was once missing from the top-level key list.
  const Case c = parse_case(kValid + "limits: {max_overlap_fraction: 0.1}\n", "case.yaml");
  EXPECT_DOUBLE_EQ(c.max_overlap_fraction, 0.1);
  EXPECT_NE(error_of(kValid + "limits: {max_overlap_fraction: 2}\n").find("must not exceed 1"),
            std::string::npos);
}

TEST(CaseFile, BoundaryMotionsAndMeshesAreRead) {
  // A mesh placed by scale and offset with its own reference point, turning on a linear ramp
  // about y; a roller whose spin is a constant rotation about its own axis; a platform plane
  // lowered by a step profile.
  const std::string text = std::string(R"(materials:
  m: {density: 1000, youngs_modulus: 1.0e7, poisson_ratio: 0.3}
contact: {damping_ratio: 0.2}
bond: {alpha: 1, criterion: never, equilibrium_overlap: 1.0e-6, damping_ratio: 1.0}
time: {step: 1.0e-6, end: 1.0e-3}
particles:
  - {material: m, radius: 1.0e-4, position: [0.0, 0.0, -0.002]}
walls:
  - {type: plane, point: [0, 0, -0.0049], normal: [0, 0, 1], material: m, name: platform,
     motion: [{time: 0.001, velocity: [0, 0, -0.1]}, {time: 0.002}]}
  - {type: roller, point: [0.02, 0, 0.01], radius: 0.002, spin: -3, material: m}
  - type: mesh
    file: )") + BONDEM_CASES_DIR +
                           R"(/geometry/drum.stl
    scale: 1.0e-3
    offset: [0.0, 0.0, 0.001]
    center: [0.0, 0.0, 0.0]
    material: m
    name: drum
    motion:
      interpolation: linear
      axis: [0, 2, 0]
      keys: [{time: 0.0}, {time: 0.01, angular_velocity: 4.0}]
)";
  const Case c = parse_case(text, "case.yaml");
  ASSERT_EQ(c.boundaries.size(), 3U);
  const Boundary& platform = c.boundaries[0];
  ASSERT_EQ(platform.motion.keys.size(), 2U);
  EXPECT_EQ(platform.motion.keys[0].velocity, Eigen::Vector3d(0, 0, -0.1));
  EXPECT_EQ(platform.motion.keys[1].velocity, Eigen::Vector3d::Zero());             // default
  EXPECT_EQ(motion_at(platform.motion, 0.0005).velocity, Eigen::Vector3d::Zero());  // before
  EXPECT_EQ(motion_at(platform.motion, 0.0015).velocity.z(), -0.1);
  const Boundary& roller = c.boundaries[1];
  EXPECT_EQ(roller.motion.spin, -3.0);
  EXPECT_EQ(roller.motion.axis, Eigen::Vector3d::UnitY());  // the roller's own axis
  EXPECT_DOUBLE_EQ(rotation_speed(roller), 3.0 * 0.002);
  const Boundary& drum = c.boundaries[2];
  ASSERT_TRUE(std::holds_alternative<MeshShape>(drum.shape));
  EXPECT_EQ(drum.center, Eigen::Vector3d::Zero());
  EXPECT_EQ(drum.motion.interpolation, MotionInterpolation::kLinear);
  EXPECT_EQ(drum.motion.axis, Eigen::Vector3d::UnitY());  // normalized
  // Half-way up the ramp: half the rate; a mesh turns its geometry, a roller does not.
  EXPECT_DOUBLE_EQ(motion_at(drum.motion, 0.005).angular_velocity, 2.0);
  EXPECT_TRUE(drum.turns());
  EXPECT_FALSE(roller.turns());
  // The drum's vertices in its frame: the file's millimetres scaled, offset 1 mm up, relative to
  // the reference point; its wall 5 mm from the axis.
  const MeshSurface& surface = *std::get<MeshShape>(drum.shape).surface;
  EXPECT_NEAR(surface.box_max.z(), 0.006, 1e-12);
  EXPECT_NEAR(surface.box_min.z(), -0.004, 1e-12);
  // 4.5 mm below the drum's centre at z = 1 mm: 0.5 mm from a round wall; the 96-gon's wall lies
  // between the circle and its chords, up to 5 mm (1 - cos(pi / 96)) inside it, and its normal
  // within pi / 96 of the radial direction (to the single precision the file stores, 1e-7).
  const SurfacePoint wall = nearest_surface(drum, Eigen::Vector3d(0.0, 0.0, -0.0035));
  const double sag = 0.005 * (1.0 - std::cos(std::numbers::pi / 96.0));
  EXPECT_LE(wall.gap, 0.0005 + 1e-9);
  EXPECT_GE(wall.gap, 0.0005 - sag - 1e-9);
  EXPECT_GE(wall.normal.z(), std::cos(std::numbers::pi / 96.0) - 1e-7);
}

}  // namespace
}  // namespace bondem
