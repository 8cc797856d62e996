// Whole runs: restart equivalence byte for byte, interruption and resumption, refused
// checkpoints, and blow-up detection.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "io/case_file.hpp"
#include "io/checkpoint.hpp"
#include "io/run.hpp"
#include "io/vtk_output.hpp"
#include "run_helpers.hpp"

namespace bondem {
namespace {

namespace fs = std::filesystem;

/// The CI packing case shortened; 2500 particles so that the parallel loops are used.
Case short_packing(double end_time) {
  return load_case(BONDEM_CASES_DIR "/powder_bed_packing_ci.yaml",
                   {"insert.0.count=2500", "domain.max.2=0.06", "walls.0.max.2=0.06",
                    "insert.0.region.max.2=0.055", "time.end=" + std::to_string(end_time),
                    "output.history_interval=0.0015"});
}

TEST(Restart, ContinuingACheckpointGivesTheSameBytes) {
  const fs::path whole = testing::fresh_directory("run_io_whole");
  const fs::path half = testing::fresh_directory("run_io_half");
  testing::quiet_run(short_packing(0.012), whole);
  testing::quiet_run(short_packing(0.006), half);
  // The end time is not part of the fingerprint: a checkpoint can be continued further.
  testing::quiet_run(short_packing(0.012), half, (half / "checkpoint.bin").string());
  EXPECT_TRUE(testing::file_bytes(whole / "final_state.csv") ==
              testing::file_bytes(half / "final_state.csv"));
  EXPECT_TRUE(testing::file_bytes(whole / "history.csv") ==
              testing::file_bytes(half / "history.csv"));
}

TEST(Restart, InterruptedRunResumesToTheSameResult) {
  const fs::path whole = testing::fresh_directory("run_io_uninterrupted");
  const fs::path stopped = testing::fresh_directory("run_io_interrupted");
  const Case c = short_packing(0.01);
  testing::quiet_run(c, whole);
  volatile std::sig_atomic_t stop = 1;  // as if SIGINT arrived during the first step
  EXPECT_THROW(testing::quiet_run(c, stopped, "", &stop), RunInterrupted);
  ASSERT_TRUE(fs::exists(stopped / "checkpoint.bin"));
  ASSERT_TRUE(fs::exists(stopped / "final_state.csv"));  // outputs of the state reached
  EXPECT_FALSE(testing::file_bytes(whole / "final_state.csv") ==
               testing::file_bytes(stopped / "final_state.csv"));
  testing::quiet_run(c, stopped, (stopped / "checkpoint.bin").string());
  EXPECT_TRUE(testing::file_bytes(whole / "final_state.csv") ==
              testing::file_bytes(stopped / "final_state.csv"));
}

TEST(Restart, VtkSeriesContinuesAcrossARestart) {
  const fs::path whole = testing::fresh_directory("run_io_vtk_whole");
  const fs::path resumed = testing::fresh_directory("run_io_vtk_resumed");
  Case c = short_packing(0.006);
  c.vtk_interval = 0.0015;
  testing::quiet_run(c, whole);
  volatile std::sig_atomic_t stop = 1;
  EXPECT_THROW(testing::quiet_run(c, resumed, "", &stop), RunInterrupted);
  testing::quiet_run(c, resumed, (resumed / "checkpoint.bin").string());
  // Frames at 0, 1.5, 3, 4.5, 6 ms in both: the restart drops the frame written at the
  // interruption (step 1), which an uninterrupted run does not have.
  const std::string series = testing::file_bytes(whole / "particles.pvd");
  EXPECT_EQ(std::count(series.begin(), series.end(), '\n'),
            5 + 5);  // five frames, five lines of XML
  const VtpContents last = read_vtp((whole / "particles_000004.vtp").string());
  EXPECT_EQ(last.points.size(), c.particles.size());
  ASSERT_NE(last.point_array("coordination"), nullptr);
  ASSERT_NE(last.point_array("bond_count"), nullptr);
  ASSERT_NE(last.point_array("angular_velocity"), nullptr);
  EXPECT_EQ(last.point_array("angular_velocity")->components, 3);
  // Every file (frames, collections, history, final state, checkpoint) is the same, byte for
  // byte, with the parallel loops of 2500 particles.
  std::size_t files = 0;
  for (const fs::directory_entry& entry : fs::directory_iterator(whole)) {
    ++files;
    const fs::path twin = resumed / entry.path().filename();
    EXPECT_TRUE(testing::file_bytes(entry.path()) == testing::file_bytes(twin))
        << twin << " differs or is missing";
  }
  EXPECT_EQ(files, static_cast<std::size_t>(
                       std::distance(fs::directory_iterator(resumed), fs::directory_iterator())));
  EXPECT_FALSE(fs::exists(resumed / "particles_000005.vtp"));
}

class BadCheckpoint : public ::testing::Test {
 protected:
  void SetUp() override {
    // ctest runs these cases concurrently: one directory each.
    directory_ = testing::fresh_directory(
        "run_io_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    testing::quiet_run(short_packing(0.0003), directory_);
    good_ = testing::file_bytes(directory_ / "checkpoint.bin");
    ASSERT_GT(good_.size(), 1000u);
  }
  /// The error of restarting from @p bytes (or from @p c's mismatch), "" if accepted.
  std::string error_with(const std::string& bytes, const Case& c) {
    const fs::path path = directory_ / "tampered.bin";
    std::ofstream(path, std::ios::binary) << bytes;
    try {
      testing::quiet_run(c, directory_ / "resumed", path.string());
    } catch (const CaseError& e) {
      return e.what();
    }
    return "";
  }
  fs::path directory_;
  std::string good_;
};

TEST_F(BadCheckpoint, IntactCheckpointIsAccepted) {
  EXPECT_EQ(error_with(good_, short_packing(0.0006)), "");
}

TEST_F(BadCheckpoint, FlippedByteIsRefused) {
  std::string bytes = good_;
  bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x10);
  EXPECT_NE(error_with(bytes, short_packing(0.0006)).find("checksum mismatch"), std::string::npos);
}

TEST_F(BadCheckpoint, TruncatedIsRefused) {
  EXPECT_NE(error_with(good_.substr(0, good_.size() - 9), short_packing(0.0006)).find("truncated"),
            std::string::npos);
}

TEST_F(BadCheckpoint, OtherVersionIsRefused) {
  std::string bytes = good_;
  bytes[8] = static_cast<char>(kCheckpointVersion + 1);
  EXPECT_NE(error_with(bytes, short_packing(0.0006)).find("format version"), std::string::npos);
}

TEST_F(BadCheckpoint, NotACheckpointIsRefused) {
  EXPECT_NE(error_with("id,x,y,z\n", short_packing(0.0006)).find("not a bondem checkpoint"),
            std::string::npos);
}

/// @p bytes with the checksum recomputed, as a forger would (FNV-1a over the payload's 64-bit
/// words, then over its last bytes one at a time).
std::string with_valid_checksum(std::string bytes) {
  constexpr std::size_t header = 8 + 4 + 8;
  const std::size_t end = bytes.size() - 8;
  const std::size_t words_end = header + (end - header) / 8 * 8;
  std::uint64_t hash = 0xcbf29ce484222325ULL;
  for (std::size_t k = header; k < words_end; k += 8) {
    std::uint64_t word = 0;
    std::memcpy(&word, bytes.data() + k, 8);
    hash ^= word;
    hash *= 0x100000001b3ULL;
  }
  for (std::size_t k = words_end; k < end; ++k) {
    hash ^= static_cast<unsigned char>(bytes[k]);
    hash *= 0x100000001b3ULL;
  }
  std::memcpy(bytes.data() + bytes.size() - 8, &hash, 8);
  return bytes;
}

// Issue 12, item 10: a checksum-valid checkpoint claiming 2^60 particles made the reader allocate
// them ("vector::_M_default_append"); sizes are now checked against the file before allocating.
TEST_F(BadCheckpoint, ForgedHugeArrayIsRefusedBeforeAllocating) {
  std::string bytes = good_;
  // Payload: fingerprint, time, step, three counts, two overlaps, list builds (9 x 8 bytes), then
  // the particle count and the id array's own count.
  constexpr std::size_t particle_count = 8 + 4 + 8 + 9 * 8;
  const std::uint64_t huge = std::uint64_t{1} << 60;
  std::memcpy(bytes.data() + particle_count, &huge, 8);
  std::memcpy(bytes.data() + particle_count + 8, &huge, 8);
  const std::string error = error_with(with_valid_checksum(bytes), short_packing(0.0006));
  EXPECT_NE(error.find("more than the file holds"), std::string::npos) << error;
  EXPECT_NE(error.find("tampered.bin"), std::string::npos) << error;
  // The untampered checksum path still accepts the original bytes.
  EXPECT_EQ(with_valid_checksum(good_), good_);
}

// Item 10: a checksum-valid checkpoint whose particles name a material the case does not have
// would index past the material table; it is refused as not fitting the case.
TEST_F(BadCheckpoint, ForgedMaterialIndexIsRefused) {
  std::string bytes = good_;
  constexpr std::size_t particle_count = 8 + 4 + 8 + 9 * 8;
  std::uint64_t n = 0;
  std::memcpy(&n, bytes.data() + particle_count, 8);
  // After the count: the id array (its count, n ids), then the material array's count.
  const std::size_t first_material = particle_count + 8 + 8 + 8 * n + 8;
  const std::int32_t forged = 99;
  std::memcpy(bytes.data() + first_material, &forged, 4);
  const std::string error = error_with(with_valid_checksum(bytes), short_packing(0.0006));
  EXPECT_NE(error.find("does not fit the case: it holds material index 99"), std::string::npos)
      << error;
}

// Item 10: a directory given as the checkpoint failed with "std::bad_alloc".
TEST_F(BadCheckpoint, DirectoryIsRefused) {
  try {
    testing::quiet_run(short_packing(0.0006), directory_ / "resumed", directory_.string());
    FAIL() << "a directory should have been refused";
  } catch (const CaseError& e) {
    EXPECT_NE(std::string(e.what()).find("not a checkpoint file"), std::string::npos) << e.what();
  }
}

TEST_F(BadCheckpoint, OtherCaseIsRefused) {
  Case other = short_packing(0.0006);
  other.materials[0].density = 2600.0;
  EXPECT_NE(error_with(good_, other).find("different case"), std::string::npos);
}

/// Two particles under a moving roller, with temperatures: a restart of every kind of block.
const std::string kToolCase = R"(materials:
  powder: {density: 2000, youngs_modulus: 1.0e9, poisson_ratio: 0.2, specific_heat: 500,
           thermal_conductivity: 5}
  steel: {density: 7800, youngs_modulus: 2.0e9, poisson_ratio: 0.3, specific_heat: 450}
contact: {damping_ratio: 0.1, friction: 0.3}
bond: {alpha: 1, equilibrium_overlap: 1.0e-6, damping_ratio: 1.0, criterion: never}
thermal: {initial_temperature: 300, convection_coefficient: 10}
time: {step: 2.0e-8, end: 2.0e-7}
gravity: [0, 0, -9.81]
domain: {min: [0, 0, 0], max: [0.01, 0.01, 0.01]}
walls:
  - {type: plane, point: [0, 0, 0], normal: [0, 0, 1], material: steel, temperature: 320}
  - type: roller
    point: [0.002, 0.005, 0.006]
    radius: 0.001
    material: steel
    motion: [{time: 0, velocity: [0.05, 0, 0]}]
particles:
  - {material: powder, radius: 1.0e-4, position: [0.005, 0.005, 0.001]}
  - {material: powder, radius: 1.2e-4, position: [0.006, 0.005, 0.001]}
output: {directory: out}
)";

// Issue 13: the fingerprint covers the whole case. A restart of a case that differs in anything
// that shapes the trajectory is refused; a later end and other outputs are accepted.
// A distributed restart reads every particle's position, then only its part's rows: the rows
// kept are those of the whole read, values and list positions bit for bit, with the pairs that
// touch a kept particle; a mark per row that does not match the file is refused.
TEST(PartialCheckpoint, KeepsTheMarkedRowsAndTheirPairs) {
  const fs::path directory = testing::fresh_directory("run_io_partial_checkpoint");
  // The bonded frictional pour: its pairs carry springs and bonds.
  Case c = load_case(BONDEM_TEST_CASES_DIR "/storage_order.yaml", {"time.end=0.0006"});
  c.vtk_interval = 0.0;
  testing::quiet_run(c, directory);
  const std::string path = (directory / "checkpoint.bin").string();
  const Checkpoint whole = read_checkpoint(path);
  const Particles& all = whole.particles;
  const Particles where = read_checkpoint_positions(path);
  ASSERT_EQ(where.size(), all.size());
  for (std::size_t k = 0; k < all.size(); ++k) {
    EXPECT_EQ(where.id[k], all.id[k]);
    EXPECT_EQ(where.z[k], all.z[k]);
    EXPECT_EQ(where.radius[k], all.radius[k]);
  }
  // Every third row.
  std::vector<std::uint8_t> keep(all.size(), 0);
  for (std::size_t k = 0; k < keep.size(); k += 3) keep[k] = 1;
  std::vector<std::uint64_t> rows;
  for (std::size_t k = 0; k < keep.size(); ++k) {
    if (keep[k] != 0) rows.push_back(k);
  }
  const Checkpoint part = read_checkpoint(path, rows);
  EXPECT_EQ(part.file_particles, all.size());
  const Particles& p = part.particles;
  std::size_t at = 0;
  const auto width = static_cast<std::size_t>(3 * all.walls);
  for (std::size_t k = 0; k < all.size(); ++k) {
    if (keep[k] == 0) continue;
    ASSERT_LT(at, p.size());
    EXPECT_EQ(p.id[at], all.id[k]);
    EXPECT_EQ(p.x[at], all.x[k]);
    EXPECT_EQ(p.vy[at], all.vy[k]);
    EXPECT_EQ(p.wz[at], all.wz[k]);
    EXPECT_EQ(part.stepper.list.z0[at], whole.stepper.list.z0[k]);
    for (std::size_t v = 0; v < width; ++v) {
      EXPECT_EQ(p.wall_slip[at * width + v], all.wall_slip[k * width + v]);
    }
    ++at;
  }
  EXPECT_EQ(at, p.size());
  std::vector<std::pair<std::int64_t, std::int64_t>> expected, kept;
  const auto is_kept = [&](std::int64_t id) {
    return std::binary_search(p.id.begin(), p.id.end(), id);
  };
  for (const SlipRecord& s : whole.stepper.slips) {
    if (is_kept(s.first_id) || is_kept(s.second_id)) expected.emplace_back(s.first_id, s.second_id);
  }
  for (const SlipRecord& s : part.stepper.slips) kept.emplace_back(s.first_id, s.second_id);
  ASSERT_FALSE(expected.empty());
  ASSERT_GT(whole.stepper.slips.size(), expected.size());  // some pairs are left out
  EXPECT_EQ(kept, expected);
  // A row beyond the file's, and rows out of order, are refused.
  EXPECT_THROW(read_checkpoint(path, std::vector<std::uint64_t>{0, all.size()}), CheckpointError);
  EXPECT_THROW(read_checkpoint(path, std::vector<std::uint64_t>{2, 1}), CheckpointError);
  // The head alone: the particle count, unverified, without particles.
  const Checkpoint head = read_checkpoint(path, CheckpointScope{.head_only = true});
  EXPECT_EQ(head.file_particles, all.size());
  EXPECT_EQ(head.case_fingerprint, whole.case_fingerprint);
  EXPECT_EQ(head.particles.size(), 0u);
}

// A checkpoint longer than a block of rows (4 096) is read a block at a time, and a block without
// a kept row is skipped unread: the rows kept from the first and third blocks, none from the
// second, and the last row of the file, hold what the whole read holds.
TEST(PartialCheckpoint, SkipsTheBlocksWithoutKeptRows) {
  const fs::path directory = testing::fresh_directory("run_io_partial_checkpoint_blocks");
  const std::string text = R"(materials:
  powder: {density: 2500, youngs_modulus: 1.0e8, poisson_ratio: 0.3}
contact: {damping_ratio: 0.3, friction: 0.4}
time: {step: 2.0e-7, end: 4.0e-7}
domain: {min: [0, 0, 0], max: [0.0242, 0.0242, 0.0242], periodic: [true, true, false]}
gravity: [0, 0, -9.81]
insert:
  - {type: lattice, region: {min: [0, 0, 0], max: [0.0242, 0.0242, 0.0242]}, spacing: 0.0011, radius: 0.0005, material: powder, velocity: [0.01, 0, -0.02]}
output: {directory: out}
)";
  testing::quiet_run(parse_case(text, "blocks.yaml"), directory);
  const std::string path = (directory / "checkpoint.bin").string();
  const Checkpoint whole = read_checkpoint(path);
  const Particles& all = whole.particles;
  ASSERT_GT(all.size(), 2u * 4096u);  // 22^3 = 10 648 rows: three blocks
  std::vector<std::uint64_t> rows{0, 1, 4095, 8192, 8200, all.size() - 1};
  for (const bool positions_only : {false, true}) {
    const Checkpoint part =
        read_checkpoint(path, CheckpointScope{.rows = &rows, .positions_only = positions_only});
    EXPECT_EQ(part.file_particles, all.size());
    ASSERT_EQ(part.particles.size(), rows.size());
    for (std::size_t at = 0; at < rows.size(); ++at) {
      const std::size_t k = rows[at];
      EXPECT_EQ(part.particles.id[at], all.id[k]) << k;
      EXPECT_EQ(part.particles.x[at], all.x[k]) << k;
      EXPECT_EQ(part.particles.z[at], all.z[k]) << k;
      EXPECT_EQ(part.particles.radius[at], all.radius[k]) << k;
      if (positions_only) continue;
      EXPECT_EQ(part.particles.vz[at], all.vz[k]) << k;
      EXPECT_EQ(part.particles.wy[at], all.wy[k]) << k;
      EXPECT_EQ(part.stepper.list.x0[at], whole.stepper.list.x0[k]) << k;
    }
  }
}

TEST(Restart, OnlyEndTimeAndOutputsMayChange) {
  const fs::path directory = testing::fresh_directory("run_io_tool_case");
  testing::quiet_run(parse_case(kToolCase, "tool.yaml"), directory);
  const std::string checkpoint = (directory / "checkpoint.bin").string();
  const auto restart_error = [&](const std::vector<std::string>& changes) -> std::string {
    std::vector<std::string> overrides = {"time.end=4.0e-7"};
    overrides.insert(overrides.end(), changes.begin(), changes.end());
    const fs::path continued = testing::fresh_directory("run_io_tool_case_continued");
    fs::copy(directory, continued);
    try {
      testing::quiet_run(parse_case(kToolCase, "tool.yaml", overrides), continued, checkpoint);
    } catch (const CaseError& e) {
      return e.what();
    }
    return "";
  };
  for (const char* change : {"materials.powder.youngs_modulus=1.1e9",  // a material property
                             "walls.1.motion.0.velocity.0=0.06",       // a tool motion key
                             "thermal.convection_coefficient=11",      // a thermal key
                             "bond.damping_ratio=0.9",                 // the bond law
                             "particles.1.position.0=0.0061",          // one particle's position
                             "walls.0.temperature=330"}) {
    EXPECT_NE(restart_error({change}).find("different case"), std::string::npos) << change;
  }
  EXPECT_EQ(restart_error({}), "");
  EXPECT_EQ(restart_error({"output.directory=elsewhere", "output.history_interval=4.0e-8",
                           "output.vtk_interval=1.0e-7", "output.checkpoint_interval=1.0e-7"}),
            "");
}

TEST(BlowUp, TooLargeTimeStepIsCaughtWithItsCause) {
  const fs::path directory = testing::fresh_directory("run_io_blow_up");
  Case c = short_packing(0.05);
  const double limit = c.time_step;
  c.time_step = 40.0 * limit;  // contacts resolved in about two steps
  RunOptions options;
  options.output_directory = directory.string();
  options.quiet = true;
  options.enforce_time_step_limit = false;
  std::ostringstream log;
  try {
    run_case(c, options, log);
    FAIL() << "the run should have been stopped";
  } catch (const BlowUpError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("step "), std::string::npos) << message;
    EXPECT_NE(message.find("particle id"), std::string::npos) << message;
    EXPECT_NE(message.find("time.step"), std::string::npos) << message;
  }
  // The last good state is a whole, finite snapshot: one row per particle after the header.
  std::ifstream last_good(directory / "last_good_state.csv");
  ASSERT_TRUE(last_good.good());
  std::string line;
  std::getline(last_good, line);
  EXPECT_EQ(line, "id,x,y,z,vx,vy,vz,radius,material,wx,wy,wz");
  std::size_t rows = 0;
  while (std::getline(last_good, line)) {
    ++rows;
    std::stringstream fields(line);
    int column = 0;
    for (std::string field; std::getline(fields, field, ',');) {
      if (column++ == 8) {
        EXPECT_EQ(field, "powder") << line;  // the material, by name
        continue;
      }
      EXPECT_TRUE(std::isfinite(std::stod(field))) << line;
    }
  }
  EXPECT_EQ(rows, c.particles.size());
  EXPECT_FALSE(fs::exists(directory / "final_state.csv"));
  // And without the override the run does not even start.
  options.enforce_time_step_limit = true;
  EXPECT_THROW(run_case(c, options, log), CaseError);
}

/// The time of the last row of the history.csv in @p directory.
double last_history_time(const fs::path& directory) {
  std::ifstream history(directory / "history.csv");
  std::string line, last;
  while (std::getline(history, line)) last = line;
  return std::strtod(last.c_str(), nullptr);  // 17 digits: the same double as the run's time
}

TEST(BlowUp, LastGoodStateIsTheStateOfTheLastHistoryRow) {
  // The state is kept on disk, not in memory: read back, it must be the very state of that row,
  // which a run of the same case ending at the row's time writes as its final state.
  const fs::path blown = testing::fresh_directory("run_io_blow_up_rows");
  const fs::path ended = testing::fresh_directory("run_io_blow_up_row_end");
  Case c = short_packing(0.05);
  c.time_step *= 40.0;  // contacts resolved in about two steps: blows up within a few rows
  c.history_interval = 5.0 * c.time_step;
  RunOptions options;
  options.output_directory = blown.string();
  options.quiet = true;
  options.enforce_time_step_limit = false;
  std::ostringstream log;
  EXPECT_THROW(run_case(c, options, log), BlowUpError);
  const double row_time = last_history_time(blown);
  // Rows after the first: the state kept at a row, not only the one kept at the start.
  ASSERT_GE(std::llround(row_time / c.time_step), 10);
  c.end_time = row_time;
  options.output_directory = ended.string();
  run_case(c, options, log);
  EXPECT_TRUE(testing::file_bytes(blown / "last_good_state.csv") ==
              testing::file_bytes(ended / "final_state.csv"));
  // The scratch file was unlinked when opened: nothing but the outputs is left.
  for (const fs::directory_entry& entry : fs::directory_iterator(blown)) {
    EXPECT_EQ(entry.path().filename().string().find(".bondem_last_good"), std::string::npos);
  }
}

}  // namespace
}  // namespace bondem
