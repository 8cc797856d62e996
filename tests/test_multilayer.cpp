// The multilayer CI case end to end (cases/multilayer_spreading_ci.yaml): two doses streamed onto
// a feed floor, each spread by a blade into a pit whose platform is lowered by one layer (200 um)
// between them, the overflow removed. One run, shared by the tests of the process; ctest runs the
// Multilayer suite as one test (tests/CMakeLists.txt), so that the case runs once.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>

#include "io/case_file.hpp"
#include "io/run.hpp"
#include "io/run_observers.hpp"
#include "run_helpers.hpp"

namespace bondem {
namespace {

namespace fs = std::filesystem;

constexpr double kDensity = 4430.0;                   // ti64, the only powder of the case
constexpr double kLayerHeight = 200e-6;               // the platform's step [m]
constexpr double kPitMin = 0.6e-3, kPitMax = 1.2e-3;  // the platform's extent along x [m]
constexpr double kBladeEdge = 250e-6;                 // the blade's bottom edge above the floor

struct MultilayerRun {
  Case c;
  fs::path directory;
};

const MultilayerRun& multilayer_run() {
  static const MultilayerRun run = [] {
    MultilayerRun r;
    r.c = load_case(BONDEM_CASES_DIR "/multilayer_spreading_ci.yaml");
    r.directory = testing::fresh_directory("multilayer_ci");
    testing::quiet_run(r.c, r.directory);
    return r;
  }();
  return run;
}

double sphere_volume(double r) {
  return 4.0 / 3.0 * std::numbers::pi * r * r * r;
}

TEST(Multilayer, EveryParticleInsertedIsInTheBedElsewhereOrRemoved) {
  const MultilayerRun& run = multilayer_run();
  const testing::CsvTable history = testing::read_csv(run.directory / "history.csv");
  const std::size_t last = history.rows.size() - 1;
  const double inserted = history.number(last, "inserted");
  const double removed = history.number(last, "removed");
  // Both doses came in whole (50 000/s for 6 ms each), and the blade pushed what the pit could
  // not hold over its far edge, out of the domain.
  EXPECT_EQ(inserted, 2.0 * 300.0);
  EXPECT_GT(removed, 100.0);

  // final_state.csv: the bed is what lies over the platform below the blade's edge; the rest is
  // the thin film the blade leaves on the feed floor and the overflow still falling.
  const testing::CsvTable state = testing::read_csv(run.directory / "final_state.csv");
  double bed_mass = 0.0, other_mass = 0.0, bed_volume = 0.0;
  for (std::size_t i = 0; i < state.rows.size(); ++i) {
    const double x = state.number(i, "x"), z = state.number(i, "z"), r = state.number(i, "radius");
    const double mass = kDensity * sphere_volume(r);
    if (x > kPitMin && x < kPitMax && z < kBladeEdge) {
      bed_mass += mass;
      bed_volume += sphere_volume(r);
    } else {
      other_mass += mass;
    }
  }
  EXPECT_EQ(history.number(last, "particles"), static_cast<double>(state.rows.size()));
  EXPECT_EQ(static_cast<double>(state.rows.size()) + removed, inserted);
  // By mass, to rounding: the run and this test sum ~400 masses in different orders.
  const double inserted_mass = history.number(last, "inserted_mass");
  EXPECT_NEAR(bed_mass + other_mass + history.number(last, "removed_mass"), inserted_mass,
              1e-12 * inserted_mass);
  EXPECT_GT(bed_mass, other_mass);  // the doses went into the pit, not onto the floor

  // The layers' boxes lie inside the pit, one above the other: the solid they measured is part of
  // the bed (which only gains particles after a layer is measured).
  const testing::CsvTable layers = testing::read_csv(run.directory / "layers.csv");
  const LayerRegion& box = run.c.layers->region;
  const double slab = (box.x_max - box.x_min) * (box.y_max - box.y_min) * box.layer_height;
  double measured = 0.0;
  for (std::size_t n = 0; n < layers.rows.size(); ++n) {
    measured += layers.number(n, "solid_fraction") * slab;
  }
  EXPECT_LT(measured, bed_volume);
}

TEST(Multilayer, TheBedRisesByAboutOnePlatformStepPerLayer) {
  const MultilayerRun& run = multilayer_run();
  const testing::CsvTable layers = testing::read_csv(run.directory / "layers.csv");
  ASSERT_EQ(layers.rows.size(), 2u);
  for (const int n : {1, 2}) {
    const testing::CsvTable profile = testing::read_csv(run.directory / layer_file_name(n));
    EXPECT_EQ(profile.rows.size(), 4u) << n;  // bins: 4
  }
  // The platform's top: flush with the floor for layer 1, one step lower for layer 2 (to one
  // step's travel at 25 mm/s, 2.5 nm: its keys fall between steps).
  EXPECT_EQ(layers.number(0, "floor_z"), 0.0);
  EXPECT_NEAR(layers.number(1, "floor_z"), -kLayerHeight, 5e-9);
  EXPECT_NEAR(layers.number(1, "base_z"), layers.number(1, "floor_z") + kLayerHeight, 1e-12);

  // bed_height: the mean top surface above the platform. The blade leaves the surface at a level
  // set by its edge, so each spread raises the bed over the platform by about one platform step.
  // The first layer, spread onto the bare plate, lies lower under the edge than the next one on
  // powder (the full case: rises of 1.13 and 1.03 steps for layers 2 and 3); that difference is
  // within 0.3 step (60 um, 0.8 D50) here.
  const double first = layers.number(0, "bed_height");
  const double second = layers.number(1, "bed_height");
  EXPECT_GT(first, 0.3 * kLayerHeight);  // a layer, not a bare platform
  EXPECT_LT(first, kBladeEdge);          // and below the blade's edge
  EXPECT_NEAR(second - first, kLayerHeight, 0.3 * kLayerHeight);
  for (std::size_t n = 0; n < 2; ++n) {
    // Spread layers of this powder at 2 D90: loose (0.2-0.64) and mostly covered.
    EXPECT_GT(layers.number(n, "solid_fraction"), 0.2) << n;
    EXPECT_LT(layers.number(n, "solid_fraction"), 0.64) << n;
    EXPECT_LT(layers.number(n, "empty_fraction"), 0.3) << n;
  }
  // No pair of this case can bond: no agglomerate columns.
  EXPECT_THROW(layers.column("agglomerates"), std::out_of_range);
}

}  // namespace
}  // namespace bondem
