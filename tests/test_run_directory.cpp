// The run loop and its output directory (issue 12: counts, restarts, stale outputs, live history).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "io/case_file.hpp"
#include "io/run.hpp"
#include "run_helpers.hpp"
#include "solver/engine/stepper.hpp"

namespace bondem {
namespace {

namespace fs = std::filesystem;

/// A small pour into the CI box: 200 particles, 2000 steps of 1.5 us, box walls, a history row
/// every 133 steps, a VTK frame every 400 and a checkpoint every 667.
Case small_pour(const std::vector<std::string>& extra = {}) {
  std::vector<std::string> overrides{"insert.0.count=200", "time.end=0.003",
                                     "output.history_interval=0.0002", "output.vtk_interval=0.0006",
                                     "output.checkpoint_interval=0.001"};
  overrides.insert(overrides.end(), extra.begin(), extra.end());
  return load_case(BONDEM_CASES_DIR "/powder_bed_packing_ci.yaml", overrides);
}

/// Every file in @p directory: name -> bytes.
std::map<std::string, std::string> directory_bytes(const fs::path& directory) {
  std::map<std::string, std::string> files;
  for (const fs::directory_entry& entry : fs::directory_iterator(directory)) {
    files[entry.path().filename().string()] = testing::file_bytes(entry.path());
  }
  return files;
}

/// Names of the files of @p directory.
std::set<std::string> names(const std::map<std::string, std::string>& files) {
  std::set<std::string> result;
  for (const auto& [name, bytes] : files) result.insert(name);
  return result;
}

/// Expect two directories with the same files, byte for byte.
void expect_same_directories(const fs::path& expected, const fs::path& actual) {
  const std::map<std::string, std::string> want = directory_bytes(expected);
  const std::map<std::string, std::string> got = directory_bytes(actual);
  ASSERT_EQ(names(want), names(got));
  for (const auto& [name, bytes] : want) {
    EXPECT_TRUE(bytes == got.at(name)) << name << " differs";
  }
}

/// Lines of @p path (0 when it does not exist).
std::size_t line_count(const fs::path& path) {
  std::ifstream in(path);
  std::size_t lines = 0;
  for (std::string line; std::getline(in, line);) ++lines;
  return lines;
}

void write_file(const fs::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

// Issue 12, item 16: the frame written at an interruption stayed in the series and the walls were
// drawn again after every restart. Every file (VTK frames and collections, history, final state,
// checkpoint) must come out as an uninterrupted run writes it.
TEST(RunDirectory, InterruptedAndResumedRunWritesTheSameFilesAsAnUninterruptedOne) {
  const fs::path whole = testing::fresh_directory("run_directory_whole");
  const fs::path resumed = testing::fresh_directory("run_directory_resumed");
  const Case c = small_pour();
  testing::quiet_run(c, whole);
  volatile std::sig_atomic_t stop = 1;  // as if SIGINT arrived during the first step
  EXPECT_THROW(testing::quiet_run(c, resumed, "", &stop), RunInterrupted);
  // The interruption drew a frame of the state reached: frames at steps 0 and 1.
  ASSERT_TRUE(fs::exists(resumed / "particles_000001.vtp"));
  testing::quiet_run(c, resumed, (resumed / "checkpoint.bin").string());
  // Frames at 0, 0.6, ..., 3 ms; one wall file, written with the first frame.
  EXPECT_TRUE(fs::exists(whole / "particles_000005.vtp"));
  EXPECT_FALSE(fs::exists(whole / "particles_000006.vtp"));
  EXPECT_FALSE(fs::exists(whole / "walls_000001.vtp"));
  expect_same_directories(whole, resumed);
}

// Item 16 too: a finished run continued to a later end time drops the frame at its old end (an
// uninterrupted run to the later end has none there) and keeps the frames before it.
TEST(RunDirectory, ContinuedRunWritesTheSameFilesAsARunToTheLaterEnd) {
  const fs::path whole = testing::fresh_directory("run_directory_later_end");
  const fs::path continued = testing::fresh_directory("run_directory_continued");
  testing::quiet_run(small_pour(), whole);
  // 1.3 ms: frames at 0, 0.6, 1.2 ms and the end frame at 1.3 ms, which is not on the 0.6 ms grid.
  testing::quiet_run(small_pour({"time.end=0.0013"}), continued);
  ASSERT_TRUE(fs::exists(continued / "particles_000003.vtp"));
  const std::string frame_at_1_2_ms = testing::file_bytes(continued / "particles_000002.vtp");
  testing::quiet_run(small_pour(), continued, (continued / "checkpoint.bin").string());
  EXPECT_TRUE(testing::file_bytes(continued / "particles_000002.vtp") == frame_at_1_2_ms);
  expect_same_directories(whole, continued);
}

// Item 17: outputs of an earlier run in the same directory, and temporaries left by a SIGKILL,
// are removed at the start; files bondem does not write stay.
TEST(RunDirectory, EarlierRunsOutputsAndStaleTemporariesAreRemoved) {
  const fs::path directory = testing::fresh_directory("run_directory_stale");
  fs::create_directories(directory);
  for (const char* stale :
       {"final_state.csv", "checkpoint.bin", "last_good_state.csv", "clusters.csv", "layer.csv",
        "particles_000042.vtp", "walls_000007.vtp", "tools.pvd", "walls.pvd", "bonds.pvd",
        "bonds_000003.vtp", "state_000004.csv", "checkpoint.bin.tmp.999999999",
        "history.csv.tmp.999999998",
        // An output moved aside by a run killed before it was unlinked (StaleOutputRemoval).
        ".bondem_stale_3.tmp.999999997"}) {
    write_file(directory / stale, "from an earlier run\n");
  }
  for (const char* foreign : {"notes.txt", "history.csv.old", "particles_42.vtp"}) {
    write_file(directory / foreign, "the user's\n");
  }
  testing::quiet_run(small_pour({"output.vtk_interval=0.003"}), directory);
  const std::set<std::string> expected{
      "history.csv",          "final_state.csv",     "checkpoint.bin",      "clusters.csv",
      "particles.pvd",        "contacts.pvd",        "walls.pvd",           "particles_000000.vtp",
      "particles_000001.vtp", "contacts_000000.vtp", "contacts_000001.vtp", "walls_000000.vtp",
      "domain.vtp",           "notes.txt",           "history.csv.old",     "particles_42.vtp"};
  EXPECT_EQ(names(directory_bytes(directory)), expected);
}

// Items 4 and 17: a non-finite value in a history row is a blow-up (before, it went into
// history.csv: here the mean of temperatures near the largest double overflows while every
// temperature is finite); an earlier run's final state and checkpoint do not stay beside the
// blown-up run's history.
TEST(RunDirectory, NonFiniteHistoryValueIsABlowUpAndLeavesNoEarlierOutputs) {
  const fs::path directory = testing::fresh_directory("run_directory_non_finite");
  const auto laser_case = [](const std::string& initial_temperature) {
    return load_case(BONDEM_CASES_DIR "/laser_sintering_ci.yaml",
                     {"time.end=3e-7", "output.vtk_interval=1",
                      "thermal.initial_temperature=" + initial_temperature});
  };
  testing::quiet_run(laser_case("293.15"), directory);
  ASSERT_TRUE(fs::exists(directory / "final_state.csv"));
  try {
    testing::quiet_run(laser_case("1e308"), directory);
    FAIL() << "the run should have been stopped";
  } catch (const BlowUpError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("step 0 "), std::string::npos) << message;
    EXPECT_NE(message.find("mean_temperature = inf"), std::string::npos) << message;
  }
  EXPECT_TRUE(fs::exists(directory / "last_good_state.csv"));
  EXPECT_EQ(line_count(directory / "history.csv"), 1u);  // the header: no row with inf
  EXPECT_FALSE(fs::exists(directory / "final_state.csv"));
  EXPECT_FALSE(fs::exists(directory / "checkpoint.bin"));
  EXPECT_FALSE(fs::exists(directory / "clusters.csv"));
}

// Item 17: the end-of-run files appear with the checkpoint of their state or not at all. A write
// that fails (here clusters.csv, which a directory of that name blocks) removes the final state.
TEST(RunDirectory, FailedEndOfRunWriteLeavesNoFinalStateWithoutItsCheckpoint) {
  const fs::path directory = testing::fresh_directory("run_directory_failed_end");
  fs::create_directories(directory / "clusters.csv" / "blocker");
  EXPECT_THROW(testing::quiet_run(small_pour({"output.vtk_interval=0.003"}), directory),
               std::runtime_error);
  EXPECT_FALSE(fs::exists(directory / "final_state.csv"));
  EXPECT_TRUE(fs::exists(directory / "checkpoint.bin"));
}

TEST(RunDirectory, AnEarlierOutputLinkedElsewhereKeepsItsBytes) {
  // A run writes its large outputs over the earlier run's files of the same name (no unlink, no
  // new blocks), but not over one that another name links: a hard link made to keep an earlier
  // final state must still hold it after the next run. The peers' 20 800 lattice: a final state
  // above the 2 MiB that makes a file worth writing over.
  const fs::path directory = testing::fresh_directory("run_directory_linked_output");
  const auto lattice = [](const char* end) {
    return load_case(BONDEM_CASES_DIR "/bench/peer_lattice.yaml", {std::string("time.end=") + end});
  };
  testing::quiet_run(lattice("5e-7"), directory);
  ASSERT_GT(fs::file_size(directory / "final_state.csv"), 2u << 20);
  const std::string earlier = testing::file_bytes(directory / "final_state.csv");
  fs::create_hard_link(directory / "final_state.csv", directory / "kept_state.csv");
  const std::string earlier_checkpoint = testing::file_bytes(directory / "checkpoint.bin");
  testing::quiet_run(lattice("1e-6"), directory);
  EXPECT_TRUE(testing::file_bytes(directory / "kept_state.csv") == earlier);
  EXPECT_FALSE(testing::file_bytes(directory / "final_state.csv") == earlier);
  // The checkpoint, linked by no other name, was written over: the run's own bytes, whole.
  const fs::path again = testing::fresh_directory("run_directory_linked_output_fresh");
  testing::quiet_run(lattice("1e-6"), again);
  EXPECT_TRUE(testing::file_bytes(directory / "checkpoint.bin") ==
              testing::file_bytes(again / "checkpoint.bin"));
  EXPECT_FALSE(testing::file_bytes(directory / "checkpoint.bin") == earlier_checkpoint);
  EXPECT_TRUE(testing::file_bytes(directory / "final_state.csv") ==
              testing::file_bytes(again / "final_state.csv"));
  for (const fs::directory_entry& entry : fs::directory_iterator(directory)) {
    EXPECT_EQ(entry.path().filename().string().find(".tmp."), std::string::npos)
        << entry.path() << " left behind";
  }
}

// Item 3: an output interval longer than the run means "at the end only"; before, the step count
// of 1e300 s overflowed and every step wrote a row and a frame.
TEST(RunDirectory, IntervalsLongerThanTheRunWriteAtTheStartAndEndOnly) {
  const fs::path directory = testing::fresh_directory("run_directory_long_intervals");
  testing::quiet_run(small_pour({"output.history_interval=1e300", "output.vtk_interval=1e300",
                                 "output.checkpoint_interval=1e300"}),
                     directory);
  EXPECT_EQ(line_count(directory / "history.csv"), 1u + 2u);  // header, t = 0, t = end
  EXPECT_TRUE(fs::exists(directory / "particles_000001.vtp"));
  EXPECT_FALSE(fs::exists(directory / "particles_000002.vtp"));
}

// Item 3: a step count past the limit is refused before anything is written (the reader refuses
// it too; this is the run's own guard for cases built in code).
TEST(RunDirectory, StepCountPastTheLimitIsRefused) {
  const fs::path directory = testing::fresh_directory("run_directory_too_many_steps");
  Case c = small_pour();
  c.end_time = 1e20;  // 6.7e25 steps: overflowed the step count (0 steps ran, exit 0)
  try {
    testing::quiet_run(c, directory);
    FAIL() << "the run should have been refused";
  } catch (const CaseError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("'time.end'"), std::string::npos) << message;
    EXPECT_NE(message.find("limit of 1e+12 steps"), std::string::npos) << message;
  }
  EXPECT_FALSE(fs::exists(directory));
}

// Item 2: a restart whose end is not after the checkpoint ran -95000 steps and exited 0.
TEST(RunDirectory, RestartEndingBeforeTheCheckpointIsRefused) {
  const fs::path directory = testing::fresh_directory("run_directory_restart_end");
  testing::quiet_run(small_pour({"time.end=0.0006"}), directory);
  const std::string checkpoint = (directory / "checkpoint.bin").string();
  for (const char* end : {"time.end=0.0003", "time.end=0.0006"}) {
    try {
      testing::quiet_run(small_pour({end}), directory, checkpoint);
      ADD_FAILURE() << end << " should have been refused";
    } catch (const CaseError& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find("'time.end'"), std::string::npos) << message;
      EXPECT_NE(message.find("0.0006 s"), std::string::npos) << message;  // the checkpoint's time
    }
  }
  EXPECT_TRUE(fs::exists(directory / "final_state.csv"));  // refused before touching outputs
}

// Item 18: the resume hint is the command that was run, --set, --threads and the rest included,
// with shell quoting, and its --restart pointing at the new checkpoint.
TEST(RunDirectory, ResumeHintRepeatsTheCommandLine) {
  const fs::path directory = testing::fresh_directory("run_directory_resume_hint");
  RunOptions options;
  options.output_directory = directory.string();
  options.quiet = true;
  options.command_line = {"./bondem",
                          "run",
                          "my case.yaml",
                          "--set",
                          "time.end=0.003",
                          "--threads",
                          "2",
                          "--set",
                          "description=it's a",
                          "--restart=old.bin",
                          "--unsafe-time-step"};
  volatile std::sig_atomic_t stop = 1;
  options.stop_requested = &stop;
  std::ostringstream log;
  try {
    run_case(small_pour(), options, log);
    FAIL() << "the run should have been interrupted";
  } catch (const RunInterrupted& e) {
    const std::string message = e.what();
    const std::string expected =
        "Resume with: ./bondem run 'my case.yaml' --set time.end=0.003 --threads 2 --set "
        "'description=it'\\''s a' --unsafe-time-step --restart " +
        (directory / "checkpoint.bin").string();
    EXPECT_NE(message.find(expected), std::string::npos) << message;
    EXPECT_EQ(message.find("same --set"), std::string::npos) << message;
  }
}

// Item 19: history.csv grows while the run goes on (before, it appeared whole at the end).
TEST(RunDirectory, HistoryIsWrittenWhileTheRunGoesOn) {
  const fs::path directory = testing::fresh_directory("run_directory_live_history");
  const Case c = small_pour({"time.end=0.03", "output.history_interval=0.0003",
                             "output.vtk_interval=0.03", "output.checkpoint_interval=0.03"});
  std::atomic<bool> done{false};
  std::set<std::size_t> rows_seen_before_the_end;
  std::thread watcher([&] {
    while (!done) {
      // Read final_state.csv first: rows seen while it was absent were written during the run.
      const bool finished = fs::exists(directory / "final_state.csv");
      const std::size_t rows = line_count(directory / "history.csv");
      if (!finished && rows > 1) rows_seen_before_the_end.insert(rows);
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  });
  testing::quiet_run(c, directory);
  done = true;
  watcher.join();
  EXPECT_GE(rows_seen_before_the_end.size(), 2u) << "history.csv did not grow during the run";
  EXPECT_EQ(line_count(directory / "history.csv"), 1u + 101u);
}

}  // namespace
}  // namespace bondem
