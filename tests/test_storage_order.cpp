// Results do not depend on the order the particles are stored in: every pair is seen from its
// smaller id, every particle sums its pairs by partner id, and totals are exact sums. This is
// what a domain decomposition needs (a rank holds its particles in an order of its own).
#include <gtest/gtest.h>
#include <omp.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "io/case_file.hpp"
#include "run_helpers.hpp"

namespace bondem {
namespace {

const char* const kCase = BONDEM_TEST_CASES_DIR "/storage_order.yaml";

/// The bytes of a run's final_state.csv, history.csv and clusters.csv.
struct RunBytes {
  std::string final_state, history, clusters;
};

/// Runs the storage-order case (its text with @p appended) on @p threads threads, reordering the
/// particles by cell every @p reorder_interval list builds (0: never, insertion order throughout).
RunBytes run_stored(const std::string& appended, int reorder_interval, int threads,
                    const std::string& name) {
  const Case c = parse_case(testing::file_bytes(kCase) + appended, kCase,
                            {"neighbors.reorder_interval=" + std::to_string(reorder_interval)});
  const std::filesystem::path directory = testing::fresh_directory(name);
  const int saved = omp_get_max_threads();
  omp_set_num_threads(threads);
  testing::quiet_run(c, directory);
  omp_set_num_threads(saved);
  return {testing::file_bytes(directory / "final_state.csv"),
          testing::file_bytes(directory / "history.csv"),
          testing::file_bytes(directory / "clusters.csv")};
}

/// The run stored in insertion order on one thread against runs reordered at every build and
/// every 3 builds on two threads: the same bytes, no tolerance.
void expect_same_bytes_in_any_order(const std::string& appended, const std::string& name) {
  const RunBytes reference = run_stored(appended, 0, 1, name + "_unsorted");
  ASSERT_GT(reference.final_state.size(), 1100u * 100u);
  for (const int interval : {1, 3}) {
    const RunBytes sorted =
        run_stored(appended, interval, 2, name + "_sorted" + std::to_string(interval));
    EXPECT_TRUE(sorted.final_state == reference.final_state)
        << "final_state.csv differs, reordering every " << interval << " builds";
    EXPECT_TRUE(sorted.history == reference.history)
        << "history.csv differs, reordering every " << interval << " builds";
    EXPECT_TRUE(sorted.clusters == reference.clusters)
        << "clusters.csv differs, reordering every " << interval << " builds";
  }
}

/// Column @p name of the last row of history.csv @p text.
double last_history_value(const std::string& text, const std::string& name) {
  const std::filesystem::path path = testing::test_root() / "storage_order_history.csv";
  {
    std::ofstream out(path, std::ios::binary);
    out << text;
  }
  const testing::CsvTable table = testing::read_csv(path);
  return table.number(table.rows.size() - 1, name);
}

TEST(StorageOrder, BondedFrictionalRunIsTheSameBytesInAnyOrder) {
  // The SIMD pair pass, tangential and rolling springs, bonds formed and broken, a periodic x-y
  // plane, a floor and a moving blade (exact boundary loads, energies).
  expect_same_bytes_in_any_order("", "storage_bonded");
  const RunBytes run = run_stored("", 0, 1, "storage_bonded_check");
  EXPECT_GT(last_history_value(run.history, "bonds"), 100.0) << "the case must bond";
  EXPECT_GT(last_history_value(run.history, "bonds_broken"), 10.0) << "and break bonds";
  // The blade moves along +x: the particles it pushes load it along -x.
  EXPECT_LT(last_history_value(run.history, "load_blade_x"), 0.0) << "the blade must push";
}

TEST(StorageOrder, CohesiveRunIsTheSameBytesInAnyOrder) {
  // JKR cohesion (the scalar pair pass with per-pair contact state) instead of bonds.
  const std::string cohesive =
      "interactions:\n"
      "  - materials: [powder, powder]\n"
      "    cohesion: {model: jkr, surface_energy: 0.05}\n";
  expect_same_bytes_in_any_order(cohesive, "storage_cohesive");
}

}  // namespace
}  // namespace bondem
