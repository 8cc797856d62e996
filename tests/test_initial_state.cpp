// Multi-stage runs (`initial_state:`): a case starts from another run's checkpoint (particles,
// spins, springs and bonds by ids) or final_state.csv (particles and spins), with its own
// physics, boundaries and times.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "io/case_file.hpp"
#include "io/checkpoint.hpp"
#include "run_helpers.hpp"
#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"

namespace bondem {
namespace {

namespace fs = std::filesystem;

/// Stage 1, run once per test process: the CI pouring case to 30 ms, when the 1 500 spheres are
/// in and the first have landed (springs loaded). In a directory of the test's own: ctest runs
/// the tests of this file in parallel processes.
const fs::path& stage_one() {
  static const fs::path directory = [] {
    const fs::path d =
        testing::fresh_directory(std::string("initial_state_stage_one_") +
                                 ::testing::UnitTest::GetInstance()->current_test_info()->name());
    testing::quiet_run(load_case(BONDEM_CASES_DIR "/powder_pouring_ci.yaml", {"time.end=0.03"}), d);
    return d;
  }();
  return directory;
}

/// Stage 2: the box of the pouring case, no stream, starting from @p state; @p materials and
/// @p friction as given.
std::string stage_two(const fs::path& state, const std::string& output,
                      const std::string& materials =
                          "  powder: {density: 2500, youngs_modulus: 5.0e6, poisson_ratio: 0.3}\n"
                          "  wall: {density: 7800, youngs_modulus: 5.0e6, poisson_ratio: 0.3}\n",
                      double friction = 0.5) {
  std::ostringstream text;
  text << "materials:\n"
       << materials << "contact: {damping_ratio: 0.3, friction: " << friction << "}\n"
       << "bond: {alpha: 1, equilibrium_overlap: 5.0e-6, damping_ratio: 1.0, criterion: never}\n"
       << "gravity: [0.0, 0.0, -9.81]\n"
       << "domain: {min: [0.0, 0.0, 0.0], max: [0.012, 0.012, 0.03]}\n"
       << "walls:\n"
       << "  - {type: box, min: [0.0, 0.0, 0.0], max: [0.012, 0.012, 0.03], material: wall,"
       << " open: [z_max]}\n"
       << "initial_state: {file: " << state.string() << "}\n"
       << "time: {step: 1.0e-6, end: 2.0e-3}\n"
       << "output: {directory: " << output << ", history_interval: 1.0e-3}\n";
  return text.str();
}

/// The rows of a CSV text by column name, the first column's values as keys.
std::map<std::string, std::map<std::string, std::string>> rows_by_id(const std::string& csv) {
  std::istringstream in(csv);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header;
  std::istringstream names(line);
  for (std::string name; std::getline(names, name, ',');) header.push_back(name);
  std::map<std::string, std::map<std::string, std::string>> rows;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::map<std::string, std::string> row;
    std::string field;
    for (std::size_t k = 0; k < header.size() && std::getline(fields, field, ','); ++k) {
      row[header[k]] = field;
    }
    rows[row["id"]] = row;
  }
  return rows;
}

/// Kinetic and rotational energy (columns 2 and 3) of history row @p row (0: the first after the
/// header; -1: the last).
std::pair<double, double> energies(const fs::path& history, int row) {
  std::istringstream in(testing::file_bytes(history));
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  const std::string& line = row < 0 ? lines.back() : lines.at(static_cast<std::size_t>(row) + 1);
  std::istringstream fields(line);
  std::string time, kinetic, rotational;
  std::getline(fields, time, ',');
  std::getline(fields, kinetic, ',');
  std::getline(fields, rotational, ',');
  return {std::stod(kinetic), std::stod(rotational)};
}

TEST(InitialState, FromACheckpointTheParticlesTheirSpinsAndTheirSpringsCarryOver) {
  const fs::path checkpoint = stage_one() / "checkpoint.bin";
  const Checkpoint saved = read_checkpoint(checkpoint.string());
  // With the first stage's friction: a pair sliding at the Coulomb limit stays at the same limit
  // (a higher friction raises the spring of a pair still sliding to the new limit, by design).
  const std::string same_materials =
      "  powder: {density: 2500, youngs_modulus: 5.0e6, poisson_ratio: 0.3}\n"
      "  wall: {density: 7800, youngs_modulus: 5.0e6, poisson_ratio: 0.3}\n";
  const Case c = parse_case(stage_two(checkpoint, "unused", same_materials, 0.3), "stage_two.yaml");
  ASSERT_EQ(c.particles.size(), saved.particles.size());
  // Pairs with a loaded spring were in contact at the checkpoint: the case takes them all.
  ASSERT_GT(saved.stepper.slips.size(), 10u);
  EXPECT_EQ(c.initial_pairs.size(), saved.stepper.slips.size());

  for (std::size_t k = 0; k < c.initial_pairs.size(); ++k) {
    EXPECT_EQ(c.initial_pairs[k].first_id, saved.stepper.slips[k].first_id);
    EXPECT_EQ(c.initial_pairs[k].sx, saved.stepper.slips[k].sx);
  }

  // The stepper starts from those springs. Its first evaluation (at construction) moves each by
  // one step of sliding, and the Coulomb cap of the new friction: far less than starting them
  // from zero, which a final-state file does.
  const auto springs = [](const Case& from) {
    Scene scene = build_scene(from);
    const Stepper stepper(scene);
    std::map<std::pair<std::int64_t, std::int64_t>, Eigen::Vector3d> by_ids;
    stepper.for_each_slip(scene.particles.order_by_id(), [&](const SlipRecord& s) {
      by_ids[{s.first_id, s.second_id}] = {s.sx, s.sy, s.sz};
    });
    return by_ids;
  };
  const auto carried = springs(c);
  const auto fresh = springs(parse_case(
      stage_two(stage_one() / "final_state.csv", "unused", same_materials, 0.3), "csv.yaml"));
  std::vector<double> carried_change, fresh_change;
  for (const SlipRecord& s : saved.stepper.slips) {
    const Eigen::Vector3d before(s.sx, s.sy, s.sz);
    const auto it = carried.find({s.first_id, s.second_id});
    if (it == carried.end()) continue;
    carried_change.push_back((it->second - before).norm() / before.norm());
    const auto again = fresh.find({s.first_id, s.second_id});
    fresh_change.push_back(again == fresh.end() ? 1.0
                                                : (again->second - before).norm() / before.norm());
  }
  // A spring is kept while its pair is within the list's reach, as on any rebuild: all are.
  EXPECT_EQ(carried_change.size(), saved.stepper.slips.size());
  // Relative to the saved spring: a carried spring moves by one step of sliding (measured: 0.5 %
  // by the median, 5 % at most). A fresh start loses the springs of the pairs that stick (measured:
  // 5 of 12 change by more than half); a pair sliding at the Coulomb limit reaches the same capped
  // spring from zero within the first step, so those do not tell the two apart.
  std::size_t lost = 0;
  for (std::size_t k = 0; k < fresh_change.size(); ++k) {
    if (fresh_change[k] < 0.5) continue;
    ++lost;
    EXPECT_LT(carried_change[k], 0.1) << "a sticking spring was not carried over";
  }
  EXPECT_GE(lost, 3u) << "too few sticking pairs to tell a carried spring from a fresh one";
  Scene scene = build_scene(c);

  // Ids, positions, velocities and spins are the checkpoint's, exactly.
  const Particles& p = scene.particles;
  const Particles& q = saved.particles;
  std::map<std::int64_t, std::size_t> index;
  for (std::size_t i = 0; i < q.size(); ++i) index[q.id[i]] = i;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const std::size_t k = index.at(p.id[i]);
    EXPECT_EQ(p.radius[i], q.radius[k]);
    EXPECT_EQ(p.vz[i], q.vz[k]);
    EXPECT_EQ(p.wx[i], q.wx[k]);
    EXPECT_EQ(p.wz[i], q.wz[k]);
  }
}

TEST(InitialState, AFinalStateStartsTheRunWhereTheFirstEndedWithTheNewPhysics) {
  const fs::path directory = testing::fresh_directory("initial_state_from_csv");
  fs::create_directories(directory);
  // The materials in the other order, and a denser powder: names, not places, find them, and
  // masses follow the new density.
  const std::string swapped =
      "  wall: {density: 7800, youngs_modulus: 5.0e6, poisson_ratio: 0.3}\n"
      "  powder: {density: 5000, youngs_modulus: 5.0e6, poisson_ratio: 0.3}\n";
  const Case c =
      parse_case(stage_two(stage_one() / "final_state.csv", (directory / "out").string(), swapped),
                 "stage_two.yaml");
  ASSERT_EQ(c.particles.size(), 1500u);
  EXPECT_TRUE(c.initial_pairs.empty());  // a final state has no springs
  const Scene scene = build_scene(c);
  for (std::size_t i = 0; i < scene.particles.size(); ++i) {
    ASSERT_EQ(scene.particles.material[i], 1);
    const double r = scene.particles.radius[i];
    EXPECT_DOUBLE_EQ(scene.particles.mass[i], 5000.0 * 4.0 / 3.0 * std::numbers::pi * r * r * r);
  }

  // Every particle starts with the first stage's last values, exactly: the kinetic energies of
  // the second stage's first history row are the first stage's last ones (same density).
  const fs::path run = directory / "same_density";
  testing::quiet_run(
      parse_case(stage_two(stage_one() / "final_state.csv", run.string()), "stage_two.yaml"), run);
  // Summed over the particles in another order (stage one's list order, stage two's by id):
  // equal up to the rounding of 1 500 additions, 1e-12 relative.
  const std::pair<double, double> start = energies(run / "history.csv", 0);
  const std::pair<double, double> end = energies(stage_one() / "history.csv", -1);
  EXPECT_NEAR(start.first, end.first, 1e-12 * end.first);
  EXPECT_NEAR(start.second, end.second, 1e-12 * end.second);
  // The ids, materials and radii of stage one's particles are all there at the end.
  const auto before = rows_by_id(testing::file_bytes(stage_one() / "final_state.csv"));
  const auto after = rows_by_id(testing::file_bytes(run / "final_state.csv"));
  ASSERT_EQ(before.size(), after.size());
  for (const auto& [id, row] : before) {
    EXPECT_EQ(after.at(id).at("radius"), row.at("radius"));
    EXPECT_EQ(after.at(id).at("material"), "powder");
  }
}

TEST(InitialState, SecondStageIsTheSameBytesForAnyThreadCount) {
  const fs::path one = testing::fresh_directory("initial_state_one_thread");
  const fs::path two = testing::fresh_directory("initial_state_two_threads");
  const Case c = parse_case(stage_two(stage_one() / "checkpoint.bin", "unused"), "stage.yaml");
  const int saved = omp_get_max_threads();
  omp_set_num_threads(1);
  testing::quiet_run(c, one);
  omp_set_num_threads(2);
  testing::quiet_run(c, two);
  omp_set_num_threads(saved);
  EXPECT_TRUE(testing::file_bytes(one / "final_state.csv") ==
              testing::file_bytes(two / "final_state.csv"));
  EXPECT_TRUE(testing::file_bytes(one / "history.csv") == testing::file_bytes(two / "history.csv"));
}

/// The reader's error for stage two from a final-state file holding @p csv, "" if accepted.
std::string csv_error(const std::string& csv, const std::string& materials = "") {
  const fs::path file = testing::test_root() / "bondem_initial_state_bad.csv";
  std::ofstream(file) << csv;
  try {
    if (materials.empty()) {
      parse_case(stage_two(file, "unused"), "stage.yaml");
    } else {
      parse_case(stage_two(file, "unused", materials), "stage.yaml");
    }
  } catch (const CaseError& e) {
    return e.what();
  }
  return "";
}

TEST(InitialState, BadStateFilesAreRefusedWithTheirLine) {
  const std::string header = "id,x,y,z,vx,vy,vz,radius,material,wx,wy,wz\n";
  const std::string good = "3,0.006,0.006,0.005,0,0,0,0.0004,powder,0,0,1\n";
  EXPECT_EQ(csv_error(header + good), "");
  EXPECT_NE(csv_error(header + "3,0.006,0.006,0.005,0,0,0,0.0004,sand,0,0,1\n")
                .find("bondem_initial_state_bad.csv:2: material 'sand' is not among"),
            std::string::npos);
  EXPECT_NE(csv_error(header + good + "4,0.006,0.006,nan,0,0,0,0.0004,powder,0,0,1\n")
                .find(":3: 'z' is 'nan', not a finite number"),
            std::string::npos);
  EXPECT_NE(csv_error(header + good + good).find("id 3 twice"), std::string::npos);
  EXPECT_NE(csv_error("id,x,y,z,vx,vy,vz,radius\n3,0.006,0.006,0.005,0,0,0,0.0004\n")
                .find("no column 'material'"),
            std::string::npos);
  EXPECT_NE(
      csv_error(header + "3,0.006,0.006,0.0001,0,0,0,0.0004,powder,0,0,1\n").find("overlaps wall"),
      std::string::npos);
  EXPECT_NE(csv_error(header).find("holds no particle"), std::string::npos);
  const std::string missing = "/nonexistent/checkpoint.bin";
  try {
    parse_case(stage_two(missing, "unused"), "stage.yaml");
    ADD_FAILURE() << "a missing checkpoint was accepted";
  } catch (const CaseError& e) {
    EXPECT_NE(std::string(e.what()).find("initial_state.file"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace bondem
