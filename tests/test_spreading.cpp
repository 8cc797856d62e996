// The spreading CI case end to end, and its variants with other contact models per material pair
// (powder_spreading_friction_ci.yaml, powder_spreading_cohesive_ci.yaml): each variant runs with
// the base's seed, heap and gap, and its layer is compared with the base's. The runs are shared
// within the process (spreading_run), and ctest runs the Spreading suite as one test
// (tests/CMakeLists.txt), so the base case runs once.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <future>
#include <iterator>
#include <map>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "io/case_file.hpp"
#include "io/run.hpp"
#include "io/vtk_output.hpp"
#include "run_helpers.hpp"

namespace bondem {
namespace {

/// One run of a spreading case and the loads of its history while the blade moves.
struct SpreadingRun {
  Case c;
  RunResult r;
  std::filesystem::path directory;
  /// Mean of load_substrate_x over mean -load_substrate_z: the drag of the powder on the
  /// substrate along the spreading direction per unit of its weight there.
  double substrate_drag = 0.0;
  double blade_load = 0.0;  ///< mean -load_blade_x: the force the blade pushes the powder with [N]
};

/// The mean of history.csv's columns @p names over the rows with time > @p after.
std::vector<double> history_means(const std::filesystem::path& path,
                                  const std::vector<std::string>& names, double after) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header;
  std::stringstream fields(line);
  for (std::string field; std::getline(fields, field, ',');) header.push_back(field);
  std::vector<std::size_t> columns;
  for (const std::string& name : names) {
    const auto found = std::find(header.begin(), header.end(), name);
    EXPECT_NE(found, header.end()) << name;
    columns.push_back(static_cast<std::size_t>(found - header.begin()));
  }
  std::vector<double> sums(names.size(), 0.0);
  std::size_t rows = 0;
  while (std::getline(in, line)) {
    std::vector<double> v;
    std::stringstream row(line);
    for (std::string field; std::getline(row, field, ',');) v.push_back(std::stod(field));
    if (v.size() != header.size() || !(v[0] > after)) continue;
    for (std::size_t k = 0; k < columns.size(); ++k) sums[k] += v[columns[k]];
    ++rows;
  }
  EXPECT_GT(rows, 100u) << path;
  for (double& sum : sums) sum /= static_cast<double>(rows);
  return sums;
}

/// The key of the run of cases/@p name with insertion seed @p seed (0: the case's own).
std::string run_key(const std::string& name, int seed) {
  return seed == 0 ? name : name + "_seed" + std::to_string(seed);
}

/// The run of cases/@p name, with @p seed as in run_key(); VTK frames only when @p frames. History
/// every 0.1 ms instead of the case's 1 ms: the loads are instantaneous, and their means over the
/// 24 ms of spreading need the 240 rows (the rows do not change the run).
SpreadingRun run_spreading(const std::string& name, int seed, bool frames) {
  SpreadingRun run;
  std::vector<std::string> overrides = {"output.history_interval=1e-4"};
  if (seed != 0) overrides.push_back("insert.0.seed=" + std::to_string(seed));
  run.c = load_case(BONDEM_CASES_DIR "/" + name + ".yaml", overrides);
  if (!frames) run.c.vtk_interval = 0.0;  // outputs do not change a run
  run.directory = testing::test_root() / ("bondem_spreading_" + run_key(name, seed));
  run.r = testing::quiet_run(run.c, run.directory);
  return run;
}

/// The suite's runs (case, seed), started together on first use, each on a thread of its own (a
/// run of 800 particles uses one): the suite then takes about its longest run where cores are
/// free, not the sum of five (about 70 s each). Only the base case's run writes VTK frames (the
/// one test that reads them), so that no two threads use VTK.
const std::pair<const char*, int> kSuiteRuns[] = {{"powder_spreading_ci", 0},
                                                  {"powder_spreading_friction_ci", 0},
                                                  {"powder_spreading_cohesive_ci", 0},
                                                  {"powder_spreading_ci", 11},
                                                  {"powder_spreading_cohesive_ci", 11}};

/// The run of cases/@p name (see run_key()), kept for the other tests of the process, with the
/// means of its loads while the blade moves.
const SpreadingRun& spreading_run(const std::string& name, int seed = 0) {
  static std::map<std::string, std::future<SpreadingRun>> started;
  static std::map<std::string, SpreadingRun> runs;
  if (started.empty()) {
    for (const auto& [suite_name, suite_seed] : kSuiteRuns) {
      const bool frames = std::string(suite_name) == "powder_spreading_ci" && suite_seed == 0;
      started.emplace(run_key(suite_name, suite_seed),
                      std::async(std::launch::async, run_spreading, std::string(suite_name),
                                 suite_seed, frames));
    }
  }
  const std::string key = run_key(name, seed);
  if (const auto found = runs.find(key); found != runs.end()) return found->second;
  const auto pending = started.find(key);
  SpreadingRun run =
      pending != started.end() ? pending->second.get() : run_spreading(name, seed, true);
  const auto blade = std::find_if(run.c.boundaries.begin(), run.c.boundaries.end(),
                                  [](const Boundary& b) { return b.name == "blade"; });
  const double blade_start = blade->motion.keys.back().time;
  const std::vector<double> means =
      history_means(run.directory / "history.csv",
                    {"load_substrate_x", "load_substrate_z", "load_blade_x"}, blade_start);
  run.substrate_drag = means[0] / -means[1];
  run.blade_load = -means[2];
  return runs.emplace(key, std::move(run)).first->second;
}

TEST(Spreading, CiVariantLeavesAPlausibleLayer) {
  const SpreadingRun& base = spreading_run("powder_spreading_ci");
  const Case& c = base.c;
  const RunResult& r = base.r;
  const std::filesystem::path& directory = base.directory;
  ASSERT_TRUE(r.layer.has_value());
  const LayerMetrics& layer = *r.layer;
  const double gap = c.layer->layer_height;
  // A blade pass with a gap of 2.5 x D90 deposits a sparse layer: well above nothing, well below
  // random close packing (0.64), as reported for such gaps (0.2-0.5). The mean surface height
  // lies between one D10 and the gap; no particle passes under the blade taller than the gap.
  EXPECT_GT(layer.solid_fraction, 0.15);
  EXPECT_LT(layer.solid_fraction, 0.5);
  EXPECT_GT(layer.mean_surface_height, 50e-6);
  EXPECT_LT(layer.mean_surface_height, gap);
  EXPECT_LT(layer.empty_fraction, 0.5);
  EXPECT_GT(layer.particles, 20u);
  EXPECT_EQ(r.clusters, 0u);  // criterion never: no bonded agglomerates
  EXPECT_EQ(r.largest_cluster, 0u);

  // The blade is in the VTK output as a closed box that moved along x.
  ASSERT_TRUE(std::filesystem::exists(directory / "tools.pvd"));
  const VtpContents first = read_vtp((directory / "tools_000000.vtp").string());
  const VtpContents last = read_vtp((directory / "tools_000011.vtp").string());
  EXPECT_EQ(first.polys, 6u);
  ASSERT_NE(last.cell_array("tool_index"), nullptr);
  EXPECT_NEAR(last.points[0].x() - first.points[0].x(), 0.1 * (0.044 - 0.02), 1e-9);
}

// Polished steel (powder-steel friction 0.1 instead of 0.5): the heap slides on the substrate.
// The runs are chaotic: a change anywhere gives a layer like another seed's, so the margins hold
// for every one of seeds 7, 11, 23, 31 and 43 of both cases (ranges below; the case's seed 7
// first). The base's spread over these seeds: solid fraction 0.21-0.24, roughness 38-42 um.
TEST(Spreading, PolishedSteelLetsTheHeapSlideAndLeavesAThinnerSmootherLayer) {
  const SpreadingRun& base = spreading_run("powder_spreading_ci");
  const SpreadingRun& polished = spreading_run("powder_spreading_friction_ci");
  ASSERT_TRUE(base.r.layer && polished.r.layer);
  const LayerMetrics& b = *base.r.layer;
  const LayerMetrics& p = *polished.r.layer;
  // Every substrate contact carries at most friction x its normal load, so the drag is at most
  // 0.1 of the weight on the substrate (round-off aside): 0.086 (0.084-0.088). The base's heap,
  // gripping the substrate with 0.5, drags with 0.27 (0.26-0.31) of it.
  EXPECT_LE(polished.substrate_drag, 0.1 * (1.0 + 1e-9));
  EXPECT_GT(base.substrate_drag, 0.2);
  // Sliding on the substrate instead of shearing within, the heap needs less push: the blade
  // load is 0.76 (0.75-0.84) of the base's.
  EXPECT_LT(polished.blade_load, 0.92 * base.blade_load);
  // Particles on the substrate are dragged along with the heap instead of staying in the gap:
  // a thinner, smoother, sparser layer. Roughness 0.64 (0.64-0.76) of the base's, mean height
  // 0.78 (0.76-0.80), solid fraction 0.044 (0.029-0.044) lower. The SIMD pair pass (the same laws,
  // round-off apart) gave the five seeds again as five new layers: roughness 0.89, 0.69, 0.66,
  // 0.55, 0.74 of the base's, mean height 0.71-0.88, solid fraction 0.019-0.070 lower; the
  // roughness bound covers all ten.
  EXPECT_LT(p.roughness, 0.93 * b.roughness);
  EXPECT_LT(p.mean_surface_height, 0.9 * b.mean_surface_height);
  EXPECT_LT(p.solid_fraction, b.solid_fraction - 0.015);
}

// Cohesive powder (JKR between powder particles, Bond number 5): the heap holds together and the
// blade leaves fewer particles, with bare substrate between them. One realization of 800
// particles does not show it reliably: since the cell order of 2026-12-03 (another realization
// of every seed), seed 43 left a layer like the base's (solid fraction 0.2208 against 0.2216, bare
// fraction +0.022, 85 particles against 90), where the earlier realizations of seeds 7, 11, 23,
// 31 and 43 all showed it. So the test compares the means of seeds 7 (the cases' own) and 11,
// the first two of those five (two runs more keep CI short: each takes about 40 s).
TEST(Spreading, CohesionLeavesASparserLayerWithMoreBareSubstrate) {
  // Sums over the seeds; compared as means.
  double base_solid = 0.0, cohesive_solid = 0.0, base_empty = 0.0, cohesive_empty = 0.0;
  double base_particles = 0.0, cohesive_particles = 0.0, base_load = 0.0, cohesive_load = 0.0;
  constexpr int kSeeds[] = {0, 11};  // 0: the cases' own seed, 7
  for (const int seed : kSeeds) {
    const SpreadingRun& base = spreading_run("powder_spreading_ci", seed);
    const SpreadingRun& cohesive = spreading_run("powder_spreading_cohesive_ci", seed);
    ASSERT_TRUE(base.r.layer && cohesive.r.layer);
    const LayerMetrics& b = *base.r.layer;
    const LayerMetrics& k = *cohesive.r.layer;
    base_solid += b.solid_fraction;
    cohesive_solid += k.solid_fraction;
    base_empty += b.empty_fraction;
    cohesive_empty += k.empty_fraction;
    base_particles += static_cast<double>(b.particles);
    cohesive_particles += static_cast<double>(k.particles);
    base_load += base.blade_load;
    cohesive_load += cohesive.blade_load;
    // No bond law: cohesion forms no bonded clusters; it holds contacts only.
    EXPECT_EQ(cohesive.r.clusters, 0u) << "seed " << seed;
  }
  // Seeds 7, 11: solid fraction 0.203, 0.200 -> 0.193, 0.136 (mean 0.037 lower); bare fraction
  // 0.24, 0.24 -> 0.30, 0.45 (0.14 higher); particles in the layer box 83, 89 -> 75, 65 (16
  // fewer). Seed 23 gave 0.228 -> 0.178, 0.19 -> 0.32 and 103 -> 75, seed 31 0.222 -> 0.172,
  // 0.18 -> 0.35 and 100 -> 74. The earlier realizations of the five seeds gave solid fractions
  // 0.029-0.097 lower, bare fractions 0.10-0.28 higher, 14-31 fewer particles; the margins are
  // those the single run of seed 7 was held to.
  const double seeds = static_cast<double>(std::size(kSeeds));
  EXPECT_LT(cohesive_solid / seeds, base_solid / seeds - 0.015);
  EXPECT_GT(cohesive_empty / seeds, base_empty / seeds + 0.05);
  EXPECT_LT(cohesive_particles / seeds + 5.0, base_particles / seeds);
  // The cohesive heap is stronger: the blade pushes it harder (1.17-1.51 times over the five
  // seeds before the SIMD pair pass; the mean of a load this spiky varies much between runs).
  EXPECT_GT(cohesive_load, base_load);
}

}  // namespace
}  // namespace bondem
