// The checkpoint's case fingerprint: a hash of a canonical text of the whole validated case.
// Whatever shapes the trajectory changes it; the end time and the outputs do not (a restart may
// continue a run further, with other outputs).
#include <gtest/gtest.h>
#include <omp.h>

#include <charconv>
#include <cstdint>
#include <string>
#include <vector>

#include "io/case_file.hpp"
#include "io/checkpoint.hpp"

namespace bondem {
namespace {

/// Explicit particles and a roller, besides what the shipped cases have.
const std::string kRollerCase = R"(materials:
  powder: {density: 2000, youngs_modulus: 1.0e9, poisson_ratio: 0.2}
  steel: {density: 7800, youngs_modulus: 2.0e9, poisson_ratio: 0.3}
contact: {damping_ratio: 0.1, friction: 0.3}
time: {step: 1.0e-7, end: 1.0e-4}
domain: {min: [0, 0, 0], max: [0.01, 0.01, 0.01], periodic: [true, false, false]}
walls:
  - {type: plane, point: [0, 0, 0], normal: [0, 0, 1], material: steel}
  - type: roller
    point: [0.002, 0.005, 0.006]
    axis: [0, 1, 0]
    radius: 0.001
    spin: -3
    material: steel
    motion: [{time: 0, velocity: [0.05, 0, 0]}]
particles:
  - {material: powder, radius: 1.0e-4, position: [0.005, 0.005, 0.001], velocity: [0, 0, -0.1]}
  - {material: powder, radius: 1.2e-4, position: [0.006, 0.005, 0.001]}
neighbors: {skin: 2.0e-5, reorder_interval: 10}
limits: {max_overlap_fraction: 0.2}
output: {directory: out, vtk_interval: 1.0e-5}
)";

Case spreading(const std::vector<std::string>& overrides = {}) {
  return load_case(BONDEM_CASES_DIR "/powder_spreading_ci.yaml", overrides);
}

Case sintering(const std::vector<std::string>& overrides = {}) {
  return load_case(BONDEM_CASES_DIR "/laser_sintering_ci.yaml", overrides);
}

Case roller(const std::vector<std::string>& overrides = {}) {
  return parse_case(kRollerCase, "roller.yaml", overrides);
}

TEST(CaseFingerprint, TrajectoryShapingChangesChangeIt) {
  const std::uint64_t base = case_fingerprint(spreading());
  EXPECT_EQ(base, case_fingerprint(spreading()));
  for (const char* change : {"materials.ti64.youngs_modulus=2.0e7",  // a material property
                             "walls.2.motion.1.velocity.0=0.2",      // a tool motion key
                             "walls.2.motion.1.time=0.021",          // its time
                             "walls.2.max.2=0.0021",                 // the blade's shape
                             "bond.damping_ratio=0.5",               // the bond law
                             "bond.alpha=0.5",                       // the bond law's exponent
                             "contact.rolling_friction=0.2",         // the contact law
                             "insert.0.seed=8",                      // every inserted particle
                             "insert.0.radius.d90=101.0e-6",         // a size distribution
                             "time.step=9.0e-8", "gravity.2=-9.8", "domain.periodic.1=false",
                             "neighbors.skin=1.1e-5", "analysis.layer.bins=5"}) {
    EXPECT_NE(base, case_fingerprint(spreading({change}))) << change;
  }
  const std::uint64_t thermal = case_fingerprint(sintering());
  for (const char* change :
       {"thermal.convection_coefficient=11", "thermal.radiation=false", "laser.power=9.5",
        "laser.path.0.to.1=0.00013", "bond.temperature=1250", "materials.ti64.emissivity=0.4",
        "walls.0.temperature=354"}) {
    EXPECT_NE(thermal, case_fingerprint(sintering({change}))) << change;
  }
  const std::uint64_t rolled = case_fingerprint(roller());
  for (const char* change :
       {"particles.0.position.0=0.0051", "particles.0.velocity.2=-0.2", "walls.1.spin=-2",
        "walls.1.radius=0.0011", "neighbors.reorder_interval=11",
        "limits.max_overlap_fraction=0.21", "contact.friction=0.31", "walls.0.material=powder"}) {
    EXPECT_NE(rolled, case_fingerprint(roller({change}))) << change;
  }
}

TEST(CaseFingerprint, EndTimeAndOutputsMayChange) {
  EXPECT_EQ(case_fingerprint(spreading()),
            case_fingerprint(spreading(
                {"time.end=0.05", "output.directory=elsewhere", "output.history_interval=0.002",
                 "output.vtk_interval=0.001", "output.checkpoint_interval=0.01"})));
  EXPECT_EQ(case_fingerprint(roller()),
            case_fingerprint(roller({"time.end=2.0e-4", "output.vtk_interval=2.0e-5"})));
  // A case without an output block continues with one.
  Case plain = roller();
  plain.settings.erase("output");
  plain.settings.erase("output.directory");
  plain.settings.erase("output.vtk_interval");
  EXPECT_EQ(case_fingerprint(plain), case_fingerprint(roller()));
}

/// @p value changed a little, or "" when it is not a number.
std::vector<std::string> nudged(const std::string& value) {
  if (value == "true") return {"false"};
  if (value == "false") return {"true"};
  double number = 0.0;
  const auto [end, error] = std::from_chars(value.data(), value.data() + value.size(), number);
  if (error != std::errc() || end != value.data() + value.size()) return {value + "2"};
  if (number == 0.0) return {"1e-9", "1", "-1e-9"};
  std::vector<std::string> nudges;
  for (const double factor : {1.001, 0.999, 2.0, 0.5}) {
    char buffer[32];
    const auto written = std::to_chars(buffer, buffer + sizeof buffer, number * factor);
    nudges.emplace_back(buffer, written.ptr);
  }
  return nudges;
}

// Enumerates every key the reader read in three cases (every block the reader knows is in one of
// them) and changes each: unless the reader refuses every change of it (a material's name, a
// wall type), the fingerprint must change, except for time.end and the output settings.
TEST(CaseFingerprint, EveryKeyTheReaderReadsIsInIt) {
  struct Source {
    const char* name;
    Case (*read)(const std::vector<std::string>&);
  };
  std::size_t changed = 0;
  for (const Source& source :
       {Source{"spreading", spreading}, Source{"sintering", sintering}, Source{"roller", roller}}) {
    const Case base = source.read({});
    const std::uint64_t fingerprint = case_fingerprint(base);
    for (const auto& [key, value] : base.settings) {
      if (value == "{}") continue;  // a mapping: its keys are checked one by one
      const bool may_change = key == "time.end" || key.rfind("output.", 0) == 0;
      for (const std::string& nudge : nudged(value)) {
        std::string assignment = key;
        assignment.append("=").append(nudge);
        Case other;
        try {
          other = source.read({assignment});
        } catch (const CaseError&) {
          continue;  // refused: try another change
        }
        ASSERT_EQ(other.settings.at(key) != value, true) << source.name << " " << key;
        if (may_change) {
          EXPECT_EQ(case_fingerprint(other), fingerprint) << source.name << " " << key;
        } else {
          EXPECT_NE(case_fingerprint(other), fingerprint) << source.name << " " << key;
        }
        ++changed;
        break;
      }
    }
  }
  EXPECT_GT(changed, 100u);
}

// A case built in code has no settings read from a file: its resolved fields carry it alone.
TEST(CaseFingerprint, CaseBuiltInCodeIsCovered) {
  Case base = roller();
  base.settings.clear();
  const std::uint64_t fingerprint = case_fingerprint(base);
  const auto changed = [&](auto change) {
    Case other = base;
    change(other);
    return case_fingerprint(other) != fingerprint;
  };
  EXPECT_TRUE(changed([](Case& c) { c.particles.edit(1).position.z() += 1e-9; }));
  EXPECT_TRUE(changed([](Case& c) { c.particles.edit(0).temperature = 300.0; }));
  // The roller is walls.1, the boundary after the floor.
  ASSERT_TRUE(std::holds_alternative<CylinderShape>(base.boundaries.at(1).shape));
  EXPECT_TRUE(changed([](Case& c) { c.boundaries[1].motion.keys[0].velocity.x() = 0.06; }));
  EXPECT_TRUE(changed([](Case& c) {
    std::get<CylinderShape>(c.boundaries[1].shape).axis = Eigen::Vector3d::UnitX();
  }));
  EXPECT_TRUE(changed([](Case& c) { c.boundaries[1].motion.spin = 1.0; }));
  EXPECT_TRUE(changed([](Case& c) { c.boundaries[1].motion.keys[0].angular_velocity = 1.0; }));
  EXPECT_TRUE(changed(
      [](Case& c) { c.boundaries[1].motion.interpolation = MotionInterpolation::kLinear; }));
  EXPECT_TRUE(changed([](Case& c) { c.boundaries[1].shape = SphereShape{1e-3}; }));
  EXPECT_TRUE(changed([](Case& c) { c.materials[1].poisson_ratio = 0.31; }));
  EXPECT_TRUE(changed([](Case& c) { c.boundaries[0].temperature = 300.0; }));
  EXPECT_TRUE(changed([](Case& c) { c.boundaries[0].center.z() = 1e-9; }));
  EXPECT_TRUE(changed([](Case& c) { c.contact.bond.criterion = BondCriterion::kAlways; }));
  EXPECT_TRUE(changed([](Case& c) { c.thermal = ThermalModel{}; }));
  EXPECT_TRUE(changed([](Case& c) { c.domain->periodic[2] = true; }));
  EXPECT_FALSE(changed([](Case& c) { c.end_time = 1.0; }));
  EXPECT_FALSE(changed([](Case& c) { c.output_directory = "elsewhere"; }));
  EXPECT_FALSE(changed([](Case& c) { c.vtk_interval = 0.0; }));
  EXPECT_FALSE(changed([](Case& c) { c.source = "other.yaml"; }));
}

TEST(CaseFingerprint, CanonicalTextListsEveryParticleExactly) {
  const Case c = roller({"particles.1.position.0=0.1e-2"});
  const std::string text = canonical_case_text(c);
  EXPECT_NE(text.find("case.particles.1.position.0=0.001\n"), std::string::npos) << text;
  EXPECT_NE(text.find("file.particles.1.position.0=0.001\n"), std::string::npos) << text;
  EXPECT_NE(text.find("file.walls.1.type=roller\n"), std::string::npos) << text;
  EXPECT_EQ(text.find("output"), std::string::npos) << text;
  EXPECT_EQ(text.find("time.end"), std::string::npos) << text;
}

// The particles' lines are hashed in blocks of 4096 on every thread: the value must not depend on
// the threads, and a particle in any block, the last one of a partial block included, counts.
TEST(CaseFingerprint, ManyParticlesHashTheSameOnAnyThreadCountAndEachCounts) {
  Case c = roller();
  const ParticleSpec first = c.particles.front();
  c.particles.clear();
  for (int k = 0; k < 10000; ++k) {  // two whole blocks and a partial one
    ParticleSpec p = first;
    p.position.x() = 1e-4 + 1e-6 * k;
    p.id = k;
    c.particles.push_back(p);
  }
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const std::uint64_t one_thread = case_fingerprint(c);
  omp_set_num_threads(2);
  const std::uint64_t two_threads = case_fingerprint(c);
  omp_set_num_threads(threads);
  EXPECT_EQ(one_thread, two_threads);
  for (const std::size_t k :
       {std::size_t{0}, std::size_t{4095}, std::size_t{4096}, std::size_t{9999}}) {
    Case changed = c;
    changed.particles.edit(k).velocity.z() = 1e-9;
    EXPECT_NE(case_fingerprint(changed), one_thread) << "particle " << k;
  }
  Case swapped = c;  // the same particles in another order are another case (ids by place)
  std::swap(swapped.particles.edit(10).position, swapped.particles.edit(5000).position);
  EXPECT_NE(case_fingerprint(swapped), one_thread);
}

}  // namespace
}  // namespace bondem
