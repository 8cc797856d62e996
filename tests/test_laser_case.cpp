// The laser-sintering CI variant end to end: one track over a settled layer heats, bonds and
// reports a heat-affected band where the beam went, and nowhere else.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "io/case_file.hpp"
#include "io/run.hpp"
#include "io/vtk_output.hpp"
#include "run_helpers.hpp"
#include "solver/analysis/track_metrics.hpp"

namespace bondem {
namespace {

struct Row {
  double x, y, z, radius, temperature, peak;
  int bonds;
};

std::vector<Row> read_final_state(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "id,x,y,z,vx,vy,vz,radius,temperature,peak_temperature,bonds,material,wx,wy,wz");
  std::vector<Row> rows;
  while (std::getline(in, line)) {
    std::vector<double> v;
    std::stringstream fields(line);
    // The numbers up to bonds; the material's name and the spin follow.
    for (std::string field; v.size() < 11 && std::getline(fields, field, ',');) {
      v.push_back(std::stod(field));
    }
    rows.push_back({v[1], v[2], v[3], v[7], v[8], v[9], static_cast<int>(v[10])});
  }
  return rows;
}

TEST(LaserCase, CiVariantBondsAlongTheTrackOnly) {
  const Case c = load_case(BONDEM_CASES_DIR "/laser_sintering_ci.yaml");
  ASSERT_TRUE(c.laser && c.thermal);
  const std::filesystem::path directory = testing::test_root() / "bondem_laser_ci";
  const RunResult r = testing::quiet_run(c, directory);
  ASSERT_TRUE(r.thermal.has_value());
  const ThermalReport& t = *r.thermal;
  const Laser& laser = *c.laser;

  // The beam is on for path length / speed; the deposit is sampled once per step at mid-step,
  // so the delivered energy matches to one step of absorbed power (plus the 1e-8 window tail).
  const double exposure = (laser.path[0].end - laser.path[0].start).norm() / laser.path[0].speed;
  const double delivered = laser.power * laser.absorptivity * exposure;
  EXPECT_NEAR(t.laser_energy + t.laser_missed, delivered,
              laser.power * laser.absorptivity * c.time_step + 1e-6 * delivered);
  EXPECT_GT(t.laser_energy, 0.9 * delivered);  // a settled layer hides most of the substrate

  // Bonds formed, and only between particles that reached the bonding temperature: the
  // criterion needs both hot, and none of these bonds was lost.
  EXPECT_GT(r.bonds_formed, 0);
  EXPECT_EQ(r.bonds_broken, 0);
  EXPECT_GT(t.clusters_of_two_or_more, 0u);
  const std::vector<Row> rows = read_final_state(directory / "final_state.csv");
  ASSERT_EQ(rows.size(), c.particles.size());
  int bonded_particles = 0;
  for (const Row& row : rows) {
    if (row.bonds == 0) continue;
    ++bonded_particles;
    EXPECT_GE(row.peak, c.contact.bond.temperature);
    // Hot particles lie under the beam's path: within 1.5 spot radii of the track's axis.
    EXPECT_LT(distance_to_path(laser, row.x, row.y), 1.5 * laser.spot_radius);
  }
  EXPECT_GE(bonded_particles, 2);

  // Far from the track (beyond 3 spot radii, where the beam delivers exp(-18) of its peak) the
  // powder only warms by conduction, which is slow through nanometre contact spots: it stays
  // within 50 K of the preheat.
  for (const Row& row : rows) {
    if (distance_to_path(laser, row.x, row.y) > 3.0 * laser.spot_radius) {
      EXPECT_LT(row.peak, c.thermal->initial_temperature + 50.0);
    }
  }
  // The band is about the beam's width: wider than one particle, narrower than the window.
  EXPECT_GT(t.track.width, 2.0 * 10e-6);
  EXPECT_LT(t.track.width, 6.0 * laser.spot_radius);
  EXPECT_GT(t.track.peak_temperature, c.contact.bond.temperature);

  // Temperatures reach ParaView.
  std::filesystem::path newest;
  for (const auto& entry : std::filesystem::directory_iterator(directory)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("particles_", 0) == 0 && entry.path() > newest) newest = entry.path();
  }
  const VtpContents last = read_vtp(newest.string());
  ASSERT_NE(last.point_array("temperature"), nullptr);
  ASSERT_NE(last.point_array("bond_count"), nullptr);
}

}  // namespace
}  // namespace bondem
