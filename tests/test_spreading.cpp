// The spreading CI variant end to end: a blade pass leaves a layer whose packing lies in the
// range a 2.5 x D90 gap allows.
#include <gtest/gtest.h>

#include <filesystem>
#include <sstream>

#include "io/case_file.hpp"
#include "io/run.hpp"
#include "io/vtk_output.hpp"
#include "run_helpers.hpp"

namespace bondem {
namespace {

TEST(Spreading, CiVariantLeavesAPlausibleLayer) {
  const Case c = load_case(BONDEM_CASES_DIR "/powder_spreading_ci.yaml");
  const std::filesystem::path directory = testing::test_root() / "bondem_spreading_ci";
  const RunResult r = testing::quiet_run(c, directory);
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

}  // namespace
}  // namespace bondem
