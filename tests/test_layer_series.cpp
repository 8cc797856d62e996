// analysis.layers: layers measured during a run on a lowered platform (layer_<n>.csv, layers.csv),
// their agglomerate counts when pairs can bond, restarts, and what the reader refuses.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "io/case_file.hpp"
#include "io/run.hpp"
#include "io/run_observers.hpp"
#include "run_helpers.hpp"

namespace bondem {
namespace {

namespace fs = std::filesystem;

/// A bed of bonding spheres (radius 0.25 mm, 8 x 8 x 2 on a 0.495 mm lattice, so that neighbours
/// overlap by 5 um) on a platform whose top starts at z = 0 and is lowered by one layer height,
/// 0.5 mm, between 10 and 60 ms (at 10 mm/s, slow enough for the bed to follow under gravity), in
/// a periodic 4 mm square. Layers are measured at 5 and 70 ms.
std::string bed_case(double end, const std::string& layers_extra = "",
                     const std::string& platform = "platform") {
  return R"(
materials:
  powder: {density: 2500, youngs_modulus: 5.0e6, poisson_ratio: 0.3}
  steel: {density: 7800, youngs_modulus: 5.0e6, poisson_ratio: 0.3}
contact: {damping_ratio: 0.5, friction: 0.3}
bond: {alpha: 1, equilibrium_overlap: 2.0e-6, damping_ratio: 1.0, criterion: always}
gravity: [0, 0, -9.81]
domain: {min: [0, 0, -0.003], max: [0.004, 0.004, 0.003], periodic: [true, true, false]}
walls:
  - type: blade
    name: platform
    min: [-0.001, -0.001, -0.002]
    max: [0.005, 0.005, 0.0]
    material: steel
    motion: [{time: 0.01, velocity: [0, 0, -0.01]}, {time: 0.06, velocity: [0, 0, 0]}]
  - {type: sphere, name: ball, center: [0.002, 0.002, 0.0025], radius: 0.0003, material: steel}
insert:
  - {type: lattice, region: {min: [0, 0, 0.0], max: [0.004, 0.004, 0.001]}, spacing: 0.000495,
     radius: 0.00025, material: powder}
time: {step: 1.0e-6, end: )" +
         std::to_string(end) + R"(}
analysis:
  layers: {platform: )" +
         platform + R"(, times: [0.005, 0.07], x_min: 0, x_max: 0.004, y_min: 0, y_max: 0.004,
           layer_height: 0.0005, bins: 2)" +
         layers_extra + R"(}
output: {directory: unused}
)";
}

RunResult run_bed(double end, const fs::path& directory, const std::string& restart = "") {
  return testing::quiet_run(parse_case(bed_case(end), "bed.yaml"), directory, restart);
}

TEST(LayerSeries, MeasuresEachLayerOverThePlatformAtItsTime) {
  const fs::path directory = testing::fresh_directory("layer_series");
  run_bed(0.08, directory);
  const testing::CsvTable layers = testing::read_csv(directory / "layers.csv");
  ASSERT_EQ(layers.rows.size(), 2u);
  EXPECT_EQ(layers.number(0, "layer"), 1.0);
  EXPECT_EQ(layers.number(1, "layer"), 2.0);
  EXPECT_NEAR(layers.number(0, "time"), 0.005, 1e-12);
  EXPECT_NEAR(layers.number(1, "time"), 0.07, 1e-12);
  // The platform's top: at 0, then 0.5 mm lower (to one step's travel, 20 nm).
  EXPECT_EQ(layers.number(0, "floor_z"), 0.0);
  EXPECT_NEAR(layers.number(1, "floor_z"), -0.5e-3, 2e-8);
  // Layer n stands on the n - 1 layer heights below it.
  EXPECT_EQ(layers.number(0, "base_z"), 0.0);
  EXPECT_NEAR(layers.number(1, "base_z"), layers.number(1, "floor_z") + 0.5e-3, 1e-15);
  // The bed followed the platform down. Its mean top surface stands where a layer of spheres has
  // it: on the upper lattice layer's centres (0.745 mm above the platform) plus the mean height of
  // a hemisphere over its disc, 2R/3, less the overlaps under the bed's weight (< 1 um); within
  // 5 um, for the surface grid's sampling of each disc (quarter-radius spacing) and the bed still
  // settling at 5 ms. Layer 2's box is the upper half of the bed's nominal height, so its own
  // surface height is 0.5 mm less.
  const double top = 0.745e-3 + 2.0 / 3.0 * 0.25e-3;
  EXPECT_NEAR(layers.number(0, "bed_height"), top, 5e-6);
  EXPECT_NEAR(layers.number(1, "bed_height"), top, 5e-6);
  EXPECT_NEAR(layers.number(1, "mean_surface_height"), top - 0.5e-3, 5e-6);
  // Every centre at or above a layer's base counts (no upper bound): all 128 for layer 1, the
  // upper lattice layer's 64 for layer 2.
  EXPECT_EQ(layers.number(0, "particles"), 128.0);
  EXPECT_EQ(layers.number(1, "particles"), 64.0);
  for (const int n : {1, 2}) {
    EXPECT_EQ(testing::read_csv(directory / layer_file_name(n)).rows.size(), 2u);  // bins: 2
  }
  // Squeezed neighbours bond (criterion always): the agglomerates of the end-of-run analysis
  // (clusters.csv; no bond forms or breaks once the bed rests on the platform). Each holds a
  // vertical pair of the lattice, so each reaches into both layers' boxes.
  const testing::CsvTable clusters = testing::read_csv(directory / "clusters.csv");
  ASSERT_GE(clusters.rows.size(), 1u);
  double largest = 0.0;
  for (std::size_t k = 0; k < clusters.rows.size(); ++k) {
    largest = std::max(largest, clusters.number(k, "particles"));
  }
  for (std::size_t n = 0; n < 2; ++n) {
    EXPECT_EQ(layers.number(n, "agglomerates"), static_cast<double>(clusters.rows.size())) << n;
    EXPECT_EQ(layers.number(n, "largest_agglomerate"), largest) << n;
  }
}

TEST(LayerSeries, ARestartKeepsTheLayersMeasuredBeforeItsCheckpoint) {
  const fs::path whole = testing::fresh_directory("layer_series_whole");
  const fs::path half = testing::fresh_directory("layer_series_half");
  run_bed(0.08, whole);
  run_bed(0.04, half);  // its checkpoint is at its end: after layer 1, the platform moving
  ASSERT_EQ(testing::read_csv(half / "layers.csv").rows.size(), 1u);
  run_bed(0.08, half, (half / "checkpoint.bin").string());
  for (const char* name : {"layers.csv", "layer_001.csv", "layer_002.csv", "final_state.csv"}) {
    EXPECT_TRUE(testing::file_bytes(half / name) == testing::file_bytes(whole / name)) << name;
  }
}
std::string layers_error(const std::string& text) {
  try {
    parse_case(text, "bed.yaml");
  } catch (const CaseError& e) {
    return e.what();
  }
  return "";
}

TEST(LayerSeries, TheReaderRefusesLayersItCannotMeasure) {
  EXPECT_EQ(layers_error(bed_case(0.08)), "");
  EXPECT_NE(layers_error(bed_case(0.08, ", substrate_z: 0")).find("not both"), std::string::npos);
  const std::string unknown = layers_error(bed_case(0.08, "", "plate"));
  EXPECT_NE(unknown.find("'analysis.layers.platform'"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("the boundaries: platform, ball"), std::string::npos) << unknown;
  EXPECT_NE(layers_error(bed_case(0.08, "", "ball")).find("no flat level top"), std::string::npos);
  // Times out of order.
  std::string reversed = bed_case(0.08);
  reversed.replace(reversed.find("[0.005, 0.07]"), 13, "[0.07, 0.005]");
  EXPECT_NE(layers_error(reversed).find("must increase"), std::string::npos);
  std::string fixed = bed_case(0.08);
  fixed.replace(fixed.find("platform: platform"), 18, "substrate_z: 0.0");
  EXPECT_EQ(layers_error(fixed), "");  // a fixed substrate instead of a platform
  fixed.replace(fixed.find("substrate_z: 0.0"), 16, "grid_spacing: 1.0e-4");
  EXPECT_NE(layers_error(fixed).find("substrate_z"), std::string::npos);
}

}  // namespace
}  // namespace bondem
