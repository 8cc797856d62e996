// Results do not depend on the order the particles are stored in: every pair is seen from its
// smaller id, every particle sums its pairs by partner id, and totals are exact sums. This is
// what a domain decomposition needs (a rank holds its particles in an order of its own).
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "io/case_file.hpp"
#include "io/checkpoint.hpp"
#include "run_helpers.hpp"
#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"
#include "solver/parallel/decomposition.hpp"

namespace bondem {
namespace {

const char* const kCase = BONDEM_TEST_CASES_DIR "/storage_order.yaml";

/// Runs the storage-order case (its text with @p appended, ending at @p end_time, VTK frames
/// every millisecond) on @p threads threads into a fresh directory @p name, reordering the
/// particles by cell every @p reorder_interval list builds (0: never, insertion order throughout);
/// from @p restart when given. Returns the directory.
std::filesystem::path run_stored(const std::string& appended, int reorder_interval, int threads,
                                 const std::string& name, const std::string& end_time = "0.006",
                                 const std::filesystem::path& restart = {},
                                 bool keep_directory = false) {
  const Case c = parse_case(testing::file_bytes(kCase) + appended, kCase,
                            {"neighbors.reorder_interval=" + std::to_string(reorder_interval),
                             "time.end=" + end_time, "output.vtk_interval=0.001"});
  const std::filesystem::path directory =
      keep_directory ? testing::test_root() / ("bondem_" + name) : testing::fresh_directory(name);
  const int saved = omp_get_max_threads();
  omp_set_num_threads(threads);
  testing::quiet_run(c, directory, restart.string());
  omp_set_num_threads(saved);
  return directory;
}

/// The bytes of checkpoint @p path rewritten with the case fingerprint @p fingerprint.
std::string checkpoint_bytes_with(const std::filesystem::path& path, std::uint64_t fingerprint) {
  Checkpoint checkpoint = read_checkpoint(path.string());
  checkpoint.case_fingerprint = fingerprint;
  const std::filesystem::path copy = path.parent_path() / "refingerprinted.bin";
  write_checkpoint(copy.string(), checkpoint);
  std::string bytes = testing::file_bytes(copy);
  std::filesystem::remove(copy);
  return bytes;
}

/// Every file of directory @p a (final state, history, clusters, checkpoint, VTK frames and
/// series) is in @p b with the same bytes, and @p b has no other. With @p other_fingerprint
/// (runs of cases that differ in the reordering interval, which the fingerprint covers), the
/// checkpoints are compared with the same fingerprint.
void expect_same_files(const std::filesystem::path& a, const std::filesystem::path& b,
                       const std::string& what, bool other_fingerprint = false) {
  std::size_t files = 0;
  for (const std::filesystem::directory_entry& entry : std::filesystem::directory_iterator(a)) {
    ++files;
    const std::filesystem::path twin = b / entry.path().filename();
    if (other_fingerprint && entry.path().filename() == "checkpoint.bin") {
      EXPECT_TRUE(checkpoint_bytes_with(entry.path(), 1) == checkpoint_bytes_with(twin, 1))
          << "the checkpoints' states differ, " << what;
      continue;
    }
    EXPECT_TRUE(testing::file_bytes(entry.path()) == testing::file_bytes(twin))
        << twin.filename() << " differs or is missing, " << what;
  }
  EXPECT_EQ(files, static_cast<std::size_t>(std::distance(std::filesystem::directory_iterator(b),
                                                          std::filesystem::directory_iterator())))
      << what;
}

/// The run stored in insertion order on one thread against runs reordered at every build and
/// every 3 builds on two threads: every output file the same bytes, no tolerance.
void expect_same_bytes_in_any_order(const std::string& appended, const std::string& name) {
  const std::filesystem::path reference = run_stored(appended, 0, 1, name + "_unsorted");
  ASSERT_GT(testing::file_bytes(reference / "final_state.csv").size(), 1100u * 100u);
  ASSERT_TRUE(std::filesystem::exists(reference / "checkpoint.bin"));
  ASSERT_TRUE(std::filesystem::exists(reference / "particles_000006.vtp"));
  for (const int interval : {1, 3}) {
    const std::filesystem::path sorted =
        run_stored(appended, interval, 2, name + "_sorted" + std::to_string(interval));
    expect_same_files(reference, sorted, "reordering every " + std::to_string(interval) + " builds",
                      true);
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
  const std::string history =
      testing::file_bytes(testing::test_root() / "bondem_storage_bonded_unsorted" / "history.csv");
  EXPECT_GT(last_history_value(history, "bonds"), 100.0) << "the case must bond";
  EXPECT_GT(last_history_value(history, "bonds_broken"), 10.0) << "and break bonds";
  // Exact zeros read 0, not -0 (a load is the reaction: subtracted from zero, not negated).
  EXPECT_EQ(history.find(",-0,"), std::string::npos);
  EXPECT_EQ(history.find(",-0\n"), std::string::npos);
  // The blade moves along +x: the particles it pushes load it along -x.
  EXPECT_LT(last_history_value(history, "load_blade_x"), 0.0) << "the blade must push";
}

TEST(StorageOrder, RestartFromACheckpointByIdContinuesTheSameBytes) {
  // The checkpoint holds the particles by id; the run that continues it stores them so until
  // its next reordering, while the uninterrupted run keeps its cell order: every file the same.
  const std::filesystem::path whole = run_stored("", 1, 2, "storage_restart_whole");
  const std::filesystem::path resumed = run_stored("", 1, 2, "storage_restart_resumed", "0.0025");
  run_stored("", 1, 2, "storage_restart_resumed", "0.006", resumed / "checkpoint.bin", true);
  expect_same_files(whole, resumed, "after a restart");
}

TEST(StorageOrder, CohesiveRunIsTheSameBytesInAnyOrder) {
  // JKR cohesion (the scalar pair pass with per-pair contact state) instead of bonds.
  const std::string cohesive =
      "interactions:\n"
      "  - materials: [powder, powder]\n"
      "    cohesion: {model: jkr, surface_energy: 0.05}\n";
  expect_same_bytes_in_any_order(cohesive, "storage_cohesive");
}

TEST(StreamedPairs, FillTheSameSlotsAsRecordsInEitherOrientation) {
  // A restart streams a checkpoint's pairs into the stepper's slots (StepperState::slip_source)
  // instead of holding them as records: the slots must come out the same bits, whichever way
  // round a record names its pair (its springs then change sign), and a record of a particle
  // the scene does not hold (a distributed restart's part) is passed over.
  const Case c = parse_case(testing::file_bytes(kCase), kCase);
  Scene whole = build_scene(c);
  Stepper stepper(whole);
  for (int s = 0; s < 2500; ++s) stepper.step();
  const StepperState saved = stepper.save_state();
  ASSERT_GT(saved.slips.size(), 500u);
  ASSERT_GT(stepper.contacts().bonds, 50u);

  Scene from_records_scene = build_scene(c);
  from_records_scene.particles = whole.particles;
  const Stepper from_records(from_records_scene, saved);

  std::vector<SlipRecord> records = saved.slips;
  for (std::size_t k = 0; k < records.size(); k += 2) {
    SlipRecord& r = records[k];
    std::swap(r.first_id, r.second_id);
    for (double* spring : {&r.sx, &r.sy, &r.sz, &r.rx, &r.ry, &r.rz}) *spring = -*spring;
  }
  SlipRecord stranger = records.front();
  stranger.first_id = 1'000'000'000;  // no such particle
  records.push_back(stranger);
  StepperState streamed = saved;
  streamed.slips.clear();
  streamed.slip_source = [&records](const std::function<void(const SlipRecord&)>& visit) {
    for (const SlipRecord& r : records) visit(r);
  };
  Scene from_stream_scene = build_scene(c);
  from_stream_scene.particles = whole.particles;
  const Stepper from_stream(from_stream_scene, std::move(streamed));

  const std::vector<SlipRecord> expected = from_records.save_state().slips;
  const std::vector<SlipRecord> got = from_stream.save_state().slips;
  ASSERT_EQ(expected.size(), saved.slips.size());
  ASSERT_EQ(got.size(), expected.size());
  for (std::size_t k = 0; k < got.size(); ++k) {
    const SlipRecord& a = expected[k];
    const SlipRecord& b = got[k];
    ASSERT_TRUE(a.first_id == b.first_id && a.second_id == b.second_id && a.bonded == b.bonded &&
                a.joined == b.joined && testing::same_bits(a.sx, b.sx) &&
                testing::same_bits(a.sy, b.sy) && testing::same_bits(a.sz, b.sz) &&
                testing::same_bits(a.rx, b.rx) && testing::same_bits(a.ry, b.ry) &&
                testing::same_bits(a.rz, b.rz))
        << "pair " << a.first_id << "-" << a.second_id;
  }
}

TEST(Locality, AStepOfASubdomainNeedsOnlyItsHalo) {
  // What a domain decomposition rests on: the step of the particles a subdomain owns depends on
  // nothing but them and a halo around them, bit for bit. From a state of the bonded case, the
  // owned half (a bisection) and its halo are cut out into a scene of their own and stepped once
  // from the same state; every owned particle must come out the same bytes as in the whole run.
  // The halo: partners in the list were within r_i + r_j + skin at its build and each has moved
  // less than half a skin since, so 2 r_max + 2 skin holds them all.
  const Case c = parse_case(testing::file_bytes(kCase), kCase);
  Scene whole = build_scene(c);
  Stepper stepper(whole);
  for (int s = 0; s < 2500; ++s) stepper.step();
  ASSERT_GT(stepper.contacts().bonds, 50u);
  // A step without a rebuild (a rebuild is a global decision: a distributed run takes it for
  // all ranks at once, which a scene of its own cannot know).
  StepperState state;
  Particles before;
  for (int attempt = 0;; ++attempt) {
    ASSERT_LT(attempt, 200) << "no step without a rebuild";
    state = stepper.save_state();
    before = whole.particles;
    const std::int64_t builds = stepper.neighbors().build_count();
    stepper.step();
    if (stepper.neighbors().build_count() == builds) break;
  }
  double r_max = 0.0;
  for (const double r : before.radius) r_max = std::max(r_max, r);
  const double halo = 2.0 * r_max + 2.0 * whole.skin;
  const Box domain{whole.domain.min, whole.domain.max};
  const std::vector<double> cost(before.size(), 1.0);
  const Decomposition halves =
      bisect(before.x, before.y, before.z, cost, before.id, domain, 2, halo);
  const std::vector<std::uint32_t> kept =
      subdomain_members(halves, 0, whole.domain, halo, before.x, before.y, before.z);
  std::size_t owned_count = 0;
  for (std::size_t i = 0; i < before.size(); ++i) {
    owned_count += halves.owner(before.x[i], before.y[i], before.z[i]) == 0 ? 1 : 0;
  }
  ASSERT_GT(owned_count, 300u);
  ASSERT_LT(kept.size(), before.size()) << "the halo must leave particles out";
  Scene part = build_scene(c);
  part.particles = before;
  part.particles.permute(kept);
  for (StaggeredVector<double>* axis : {&state.list.x0, &state.list.y0, &state.list.z0}) {
    StaggeredVector<double> subset(kept.size());
    for (std::size_t k = 0; k < kept.size(); ++k) subset[k] = (*axis)[kept[k]];
    axis->swap(subset);
  }
  Stepper part_stepper(part, std::move(state));
  part_stepper.step();

  std::map<std::int64_t, std::size_t> index_of;
  for (std::size_t i = 0; i < whole.particles.size(); ++i) index_of[whole.particles.id[i]] = i;
  const Particles& p = part.particles;
  const Particles& q = whole.particles;
  std::size_t compared = 0;
  for (std::size_t k = 0; k < p.size(); ++k) {
    if (halves.owner(before.x[kept[k]], before.y[kept[k]], before.z[kept[k]]) != 0) continue;
    const std::size_t i = index_of.at(p.id[k]);
    ++compared;
    const bool same = testing::same_motion(p, k, q, i) && testing::same_bits(p.fx[k], q.fx[i]) &&
                      testing::same_bits(p.fz[k], q.fz[i]) && testing::same_bits(p.tz[k], q.tz[i]);
    EXPECT_TRUE(same) << "particle id " << p.id[k];
    if (!same) break;
  }
  EXPECT_EQ(compared, owned_count);
}

}  // namespace
}  // namespace bondem
