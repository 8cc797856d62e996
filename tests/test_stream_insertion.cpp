// Insertion during a run (`insert:` entries of type stream, particle_stream.hpp): the count or mass
// due by the rate, room for every particle, new ids, and the same bytes for any thread count and
// across restarts.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "io/case_file.hpp"
#include "run_helpers.hpp"
#include "solver/engine/particle_stream.hpp"
#include "solver/engine/scene.hpp"

namespace bondem {
namespace {

namespace fs = std::filesystem;

constexpr double kRadius = 0.5e-3;

/// A stream of spheres of radius kRadius (or uniform in [0.3, 0.5] mm) into @p region.
ParticleStream make_stream(const Box& region, bool uniform_radii = false) {
  ParticleStream s;
  s.spec.region = region;
  s.spec.radius.value = kRadius;
  if (uniform_radii) {
    s.spec.radius.kind = RadiusDistribution::Kind::kUniform;
    s.spec.radius.min = 0.3e-3;
    s.spec.radius.max = kRadius;
  }
  s.spec.particle_rate = 1000.0;
  s.spec.end_time = 1.0;
  s.spec.seed = 11;
  s.spec.velocity = {0.0, 0.0, -0.5};
  s.density = 2500.0;
  return s;
}

Domain box_domain(double side, bool periodic_x = false) {
  Domain d;
  d.min = Eigen::Vector3d::Zero();
  d.max = Eigen::Vector3d::Constant(side);
  d.periodic = {periodic_x, false, false};
  return d;
}

/// Centre-to-centre distance of particles i and j, periodic images along x when @p length_x > 0.
double distance(const Particles& p, std::size_t i, std::size_t j, double length_x = 0.0) {
  double dx = p.x[i] - p.x[j];
  if (length_x > 0.0) dx -= length_x * std::round(dx / length_x);
  return std::hypot(dx, p.y[i] - p.y[j], p.z[i] - p.z[j]);
}

/// Whether no two particles of @p p overlap (touching allowed).
bool no_overlaps(const Particles& p, double length_x = 0.0) {
  for (std::size_t i = 0; i < p.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (distance(p, i, j, length_x) < p.radius[i] + p.radius[j]) return false;
    }
  }
  return true;
}

TEST(ParticleStream, InsertsTheDueCountInsideItsRegionWithNewIds) {
  const Box region{{0.001, 0.001, 0.004}, {0.009, 0.009, 0.008}};
  const ParticleStream stream = make_stream(region, true);
  Particles p;
  ParticleTally progress;
  std::int64_t next_id = 7;
  // 1000 particles/s for 10.5 ms: 10 due.
  EXPECT_EQ(
      insert_due_particles(stream, 0, 0.0105, 1, box_domain(0.01), kRadius, p, next_id, progress),
      10u);
  EXPECT_EQ(progress.count, 10);
  EXPECT_EQ(next_id, 17);
  double mass = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    EXPECT_EQ(p.id[i], 7 + static_cast<std::int64_t>(i));
    EXPECT_EQ(p.radius[i], stream_radius(stream, 0, static_cast<std::int64_t>(i)));
    EXPECT_EQ(p.vz[i], -0.5);
    const double centre[3] = {p.x[i], p.y[i], p.z[i]};
    for (int a = 0; a < 3; ++a) {
      EXPECT_GE(centre[a] - p.radius[i], region.min[a]);
      EXPECT_LE(centre[a] + p.radius[i], region.max[a]);
    }
    mass += p.mass[i];
  }
  EXPECT_EQ(progress.mass, mass);
  EXPECT_TRUE(no_overlaps(p));
  // Nothing more is due at the same time; past the end the count stops at rate x duration.
  EXPECT_EQ(
      insert_due_particles(stream, 0, 0.0105, 2, box_domain(0.01), kRadius, p, next_id, progress),
      0u);
  ParticleStream short_stream = stream;
  short_stream.spec.end_time = 0.012;
  insert_due_particles(short_stream, 0, 0.5, 3, box_domain(0.01), kRadius, p, next_id, progress);
  EXPECT_EQ(progress.count, 12);
}

TEST(ParticleStream, ThermalParticlesStartAtTheStreamsTemperature) {
  ParticleStream stream = make_stream({{0.001, 0.001, 0.001}, {0.009, 0.009, 0.009}});
  stream.spec.temperature = 450.0;
  stream.specific_heat = 500.0;
  Particles p;
  p.track_temperatures();  // a thermal run, still without particles
  ParticleTally progress;
  std::int64_t next_id = 0;
  ASSERT_EQ(
      insert_due_particles(stream, 0, 0.003, 1, box_domain(0.01), kRadius, p, next_id, progress),
      3u);
  for (std::size_t i = 0; i < p.size(); ++i) {
    EXPECT_EQ(p.temperature[i], 450.0);
    EXPECT_EQ(p.peak_temperature[i], 450.0);
    EXPECT_DOUBLE_EQ(1.0 / p.inv_heat_capacity[i], p.mass[i] * 500.0);  // m c_p
    EXPECT_EQ(p.heat_rate[i], 0.0);
  }
}

TEST(ParticleStream, NoParticleStartsInsideABoundary) {
  // A wall across the middle of the region, facing up (a platform, or a blade passing through a
  // dosing box): every particle goes in front of it, none into it.
  const ParticleStream stream = make_stream({{0.001, 0.001, 0.001}, {0.009, 0.009, 0.009}});
  Boundary wall;
  wall.name = "cut";
  wall.shape = PlaneShape{};
  wall.center = {0.005, 0.005, 0.005};
  Particles p;
  ParticleTally progress;
  std::int64_t next_id = 0;
  insert_due_particles(stream, 0, 0.05, 1, box_domain(0.01), kRadius, p, next_id, progress, {wall});
  ASSERT_EQ(p.size(), 50u);
  for (std::size_t i = 0; i < p.size(); ++i) EXPECT_GE(p.z[i], 0.005 + kRadius) << i;
}

TEST(ParticleStream, MassRateNeverRunsAheadOfTheMassDue) {
  ParticleStream stream = make_stream({{0.001, 0.001, 0.001}, {0.009, 0.009, 0.009}}, true);
  stream.spec.particle_rate = 0.0;
  stream.spec.mass_rate = 1e-3;  // kg/s: about 1.5 particles of 0.4 mm per ms
  Particles p;
  ParticleTally progress;
  std::int64_t next_id = 0;
  for (const double t : {0.001, 0.0035, 0.02, 0.05}) {
    insert_due_particles(stream, 0, t, 1, box_domain(0.01), kRadius, p, next_id, progress);
    const double due = stream.spec.mass_rate * t;
    EXPECT_LE(progress.mass, due) << t;
    // ... and is behind by less than the next particle's mass.
    const double next = sphere_mass(stream_radius(stream, 0, progress.count), stream.density);
    EXPECT_GT(progress.mass + next, due) << t;
  }
  EXPECT_GT(progress.count, 50);
}

TEST(ParticleStream, AParticleWithoutRoomWaitsAndKeepsItsSize) {
  // A face of 2 x 2 mm for spheres of 1 mm diameter: centres in a 1 mm square, which holds
  // at most four spheres that do not overlap (its corners).
  const ParticleStream stream = make_stream({{0.004, 0.004, 0.005}, {0.006, 0.006, 0.005}});
  Particles p;
  ParticleTally progress;
  std::int64_t next_id = 0;
  const Domain domain = box_domain(0.01);
  const std::size_t first =
      insert_due_particles(stream, 0, 0.1, 1, domain, kRadius, p, next_id, progress);
  EXPECT_GE(first, 1u);
  EXPECT_LE(first, 4u);
  for (std::size_t i = 0; i < p.size(); ++i) EXPECT_EQ(p.z[i], 0.005);
  EXPECT_TRUE(no_overlaps(p));
  // The face stays full at the next step; once its particles have fallen away, the waiting ones
  // come, in order and with the sizes they were drawn with.
  EXPECT_LE(insert_due_particles(stream, 0, 0.1, 2, domain, kRadius, p, next_id, progress),
            4u - first);
  const std::size_t before = p.size();
  for (std::size_t i = 0; i < p.size(); ++i) p.z[i] -= 0.003;
  EXPECT_GE(insert_due_particles(stream, 0, 0.1, 3, domain, kRadius, p, next_id, progress), 1u);
  EXPECT_EQ(p.id[before], static_cast<std::int64_t>(before));
  EXPECT_TRUE(no_overlaps(p));
}

TEST(ParticleStream, PeriodicNeighborsAcrossTheBoundaryAreRespected) {
  // A stream across the whole periodic x width: a sphere near x = L overlaps one near x = 0
  // through the boundary unless the test sees periodic images.
  constexpr double kLength = 0.004;
  Domain domain = box_domain(kLength, true);
  domain.max.z() = 0.01;
  ParticleStream stream = make_stream({{0.0, 0.0005, 0.0005}, {kLength, 0.0035, 0.0095}});
  stream.spec.particle_rate = 1e5;
  stream.spec.max_attempts = 2000;
  Particles p;
  ParticleTally progress;
  std::int64_t next_id = 0;
  insert_due_particles(stream, 0, 0.001, 1, domain, kRadius, p, next_id, progress);
  // 100 due; a 4 x 3 x 9 mm region holds far fewer spheres of 1 mm placed at random.
  EXPECT_GT(p.size(), 20u);
  EXPECT_LT(p.size(), 100u);
  EXPECT_TRUE(no_overlaps(p, kLength));
}

/// The CI pouring case to @p end_time [s]: 1 300 particles by 26 ms, past the 1 024 above which
/// loops are parallel.
Case pouring(double end_time) {
  return load_case(BONDEM_CASES_DIR "/powder_pouring_ci.yaml",
                   {"time.end=" + std::to_string(end_time), "output.history_interval=0.002"});
}

/// The values of the last row of a CSV text, by column name.
std::map<std::string, double> last_row(const std::string& csv) {
  std::istringstream in(csv);
  std::string header, line, last;
  std::getline(in, header);
  while (std::getline(in, line)) {
    if (!line.empty()) last = line;
  }
  std::map<std::string, double> row;
  std::istringstream names(header), values(last);
  std::string name, value;
  while (std::getline(names, name, ',') && std::getline(values, value, ',')) {
    row[name] = std::stod(value);
  }
  return row;
}

TEST(StreamRun, SameBytesForAnyThreadCountAndAcrossARestart) {
  const fs::path one = testing::fresh_directory("stream_one_thread");
  const fs::path two = testing::fresh_directory("stream_two_threads");
  const fs::path half = testing::fresh_directory("stream_restarted");
  const int saved = omp_get_max_threads();
  omp_set_num_threads(1);
  testing::quiet_run(pouring(0.026), one);
  omp_set_num_threads(2);
  testing::quiet_run(pouring(0.026), two);
  // The checkpoint at 13 ms carries what the stream inserted; the rest comes after the restart.
  testing::quiet_run(pouring(0.013), half);
  testing::quiet_run(pouring(0.026), half, (half / "checkpoint.bin").string());
  omp_set_num_threads(saved);
  const std::string state = testing::file_bytes(two / "final_state.csv");
  const std::string history = testing::file_bytes(two / "history.csv");
  EXPECT_TRUE(testing::file_bytes(one / "final_state.csv") == state);
  EXPECT_TRUE(testing::file_bytes(one / "history.csv") == history);
  EXPECT_TRUE(testing::file_bytes(half / "final_state.csv") == state);
  EXPECT_TRUE(testing::file_bytes(half / "history.csv") == history);

  // history.csv counts what is in the run: every particle came from the stream, 50 000/s for
  // 26 ms as room allowed, and its mass is the sum of the spheres' masses (a different order of
  // summation: rounding only).
  const std::map<std::string, double> last = last_row(history);
  std::istringstream rows(state);
  std::string line;
  std::getline(rows, line);
  std::size_t count = 0;
  double mass = 0.0;
  while (std::getline(rows, line)) {
    std::vector<std::string> fields;
    std::istringstream row(line);
    for (std::string field; std::getline(row, field, ',');) fields.push_back(field);
    const double r = std::stod(fields.at(7));  // id, x, y, z, vx, vy, vz, radius, ...
    EXPECT_EQ(fields.at(8), "powder");
    mass += sphere_mass(r, 2500.0);
    ++count;
  }
  EXPECT_EQ(last.at("particles"), static_cast<double>(count));
  EXPECT_EQ(last.at("inserted"), static_cast<double>(count));
  EXPECT_LE(count, 1300u);
  EXPECT_GT(count, 1200u);
  EXPECT_NEAR(last.at("inserted_mass"), mass, 1e-12 * mass);
}

/// A stream falling through a domain with no floor: what crosses its bottom face is removed.
Case falling_through(double end_time) {
  return parse_case(R"(
materials: {powder: {density: 2500, youngs_modulus: 5.0e6, poisson_ratio: 0.3}}
contact: {damping_ratio: 0.3, friction: 0.3}
bond: {alpha: 1, equilibrium_overlap: 5.0e-6, damping_ratio: 1.0, criterion: never}
gravity: [0.0, 0.0, -9.81]
domain: {min: [0, 0, 0], max: [0.01, 0.01, 0.02], remove_outside: true}
insert:
  - {type: stream, region: {min: [0.001, 0.001, 0.012], max: [0.009, 0.009, 0.019]},
     material: powder, rate: 40000, end: 0.04, velocity: [0, 0, -0.5], seed: 3,
     radius: {distribution: uniform, min: 3.0e-4, max: 5.0e-4}}
time: {step: 1.0e-6, end: )" +
                        std::to_string(end_time) +
                        R"(}
output: {directory: unused, history_interval: 0.002}
)",
                    "falling.yaml");
}

TEST(StreamRun, WhatLeavesTheDomainIsRemovedAndCounted) {
  const fs::path whole = testing::fresh_directory("stream_removed_whole");
  const fs::path half = testing::fresh_directory("stream_removed_half");
  testing::quiet_run(falling_through(0.05), whole);
  testing::quiet_run(falling_through(0.025), half);
  testing::quiet_run(falling_through(0.05), half, (half / "checkpoint.bin").string());
  const std::string history = testing::file_bytes(whole / "history.csv");
  EXPECT_TRUE(testing::file_bytes(half / "history.csv") == history);
  EXPECT_TRUE(testing::file_bytes(half / "final_state.csv") ==
              testing::file_bytes(whole / "final_state.csv"));
  // Mass balance: every particle inserted is in the run or was removed, by count and by mass.
  const std::map<std::string, double> last = last_row(history);
  EXPECT_EQ(last.at("inserted"), 1600.0);  // 40 000/s for 40 ms: the region never fills
  EXPECT_GT(last.at("removed"), 100.0);    // a fall of 12-19 mm from 0.5 m/s takes < 50 ms
  EXPECT_EQ(last.at("particles") + last.at("removed"), last.at("inserted"));
  std::istringstream rows(testing::file_bytes(whole / "final_state.csv"));
  std::string line;
  std::getline(rows, line);
  double mass_in_run = 0.0;
  while (std::getline(rows, line)) {
    std::vector<double> v;
    std::istringstream fields(line);
    for (std::string field; v.size() < 8 && std::getline(fields, field, ',');) {
      v.push_back(std::stod(field));
    }
    // Removed at list builds: a particle may be below the floor by less than half a skin plus
    // one step's fall since the last build (millimetres at most here).
    EXPECT_GT(v[3], -1e-3);
    mass_in_run += sphere_mass(v[7], 2500.0);
  }
  EXPECT_NEAR(mass_in_run + last.at("removed_mass"), last.at("inserted_mass"),
              1e-12 * last.at("inserted_mass"));
}

/// The reader's error for the pouring case's stream changed by @p overrides, "" if accepted.
std::string stream_error(const std::vector<std::string>& overrides) {
  try {
    load_case(BONDEM_CASES_DIR "/powder_pouring_ci.yaml", overrides);
  } catch (const CaseError& e) {
    return e.what();
  }
  return "";
}

TEST(StreamReader, RefusesStreamsItCannotRun) {
  EXPECT_EQ(stream_error({}), "");
  EXPECT_NE(stream_error({"insert.0.mass_rate=0.01"}).find("exactly one of rate"),
            std::string::npos);
  // A uniform distribution with its upper bound unset cannot be given here: the reader requires
  // both. A normal one without cut-offs can, and has no largest particle.
  const std::string unbounded = R"(
materials: {powder: {density: 2500, youngs_modulus: 5.0e6, poisson_ratio: 0.3}}
contact: {damping_ratio: 0.3}
bond: {alpha: 1, equilibrium_overlap: 5.0e-6, damping_ratio: 1.0, criterion: never}
domain: {min: [0, 0, 0], max: [0.01, 0.01, 0.01]}
insert:
  - {type: stream, region: {min: [0, 0, 0], max: [0.01, 0.01, 0.01]}, material: powder,
     rate: 100, radius: {distribution: normal, mean: 4.0e-4, std_dev: 5.0e-5, min: 3.0e-4}}
time: {step: 1.0e-6, end: 1.0e-3}
)";
  try {
    parse_case(unbounded, "unbounded.yaml");
    ADD_FAILURE() << "a stream without a largest radius was accepted";
  } catch (const CaseError& e) {
    EXPECT_NE(std::string(e.what()).find("insert.0.radius"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("both bounds"), std::string::npos) << e.what();
  }
  EXPECT_NE(stream_error({"insert.0.region.max.2=0.05"}).find("outside the domain along z"),
            std::string::npos);
  EXPECT_NE(stream_error({"insert.0.region.max.2=0.0105"}).find("less than the largest diameter"),
            std::string::npos);
  EXPECT_EQ(stream_error({"insert.0.region.max.2=0.01"}), "");  // a face
  EXPECT_NE(stream_error({"insert.0.end=0.005", "insert.0.start=0.01"}).find("not after its start"),
            std::string::npos);
  EXPECT_NE(stream_error({"insert.0.rates=5"}).find("rates"), std::string::npos);
}

}  // namespace
}  // namespace bondem
