// The shipped cases with triangle-mesh boundaries, end to end: spreading with the profiled STL
// blade over a build platform that lowers by one layer (cases/powder_spreading_stl_ci.yaml), and
// the rotating STL drum (cases/rotating_drum_ci.yaml) with and without friction between the beads.
// Each case is one test: ctest runs every test in a process of its own, and a run is the cost.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <variant>
#include <vector>

#include "io/case_file.hpp"
#include "io/run.hpp"
#include "io/vtk_output.hpp"
#include "run_helpers.hpp"
#include "solver/analysis/repose.hpp"

namespace bondem {
namespace {

/// history.csv as numbers: its header and its rows.
struct History {
  std::vector<std::string> header;
  std::vector<std::vector<double>> rows;

  /// Index of column @p name (fails the test and returns 0 when it is missing).
  [[nodiscard]] std::size_t column(const std::string& name) const {
    const auto found = std::find(header.begin(), header.end(), name);
    EXPECT_NE(found, header.end()) << "history.csv has no column " << name;
    return found == header.end() ? 0 : static_cast<std::size_t>(found - header.begin());
  }
  /// Values of column @p name over the rows with @p from < time <= @p to.
  [[nodiscard]] std::vector<double> values(const std::string& name, double from, double to) const {
    const std::size_t k = column(name);
    std::vector<double> v;
    for (const std::vector<double>& row : rows) {
      if (row[0] > from && row[0] <= to) v.push_back(row[k]);
    }
    return v;
  }
};

History read_history(const std::filesystem::path& path) {
  History history;
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  std::stringstream fields(line);
  for (std::string field; std::getline(fields, field, ',');) history.header.push_back(field);
  while (std::getline(in, line)) {
    std::vector<double> row;
    std::stringstream values(line);
    for (std::string field; std::getline(values, field, ',');) row.push_back(std::stod(field));
    if (row.size() == history.header.size()) history.rows.push_back(std::move(row));
  }
  return history;
}

/// Mean and standard error of the mean of @p v (at least 2 values).
struct MeanAndError {
  double mean = 0.0;
  double error = 0.0;
};

MeanAndError mean_and_error(const std::vector<double>& v) {
  EXPECT_GE(v.size(), 2u);
  MeanAndError m;
  for (const double x : v) m.mean += x;
  m.mean /= static_cast<double>(v.size());
  double squares = 0.0;
  for (const double x : v) squares += (x - m.mean) * (x - m.mean);
  m.error = std::sqrt(squares / static_cast<double>(v.size() - 1) / static_cast<double>(v.size()));
  return m;
}

/// The weight of the case's particles [N]: their mass from radius and material density times |g|.
double bed_weight(const Case& c) {
  double mass = 0.0;
  for (const ParticleSpec& p : c.particles) {
    mass += c.materials[static_cast<std::size_t>(p.material)].density * 4.0 / 3.0 *
            std::numbers::pi * p.radius * p.radius * p.radius;
  }
  return mass * c.gravity.norm();
}

const Boundary& boundary_named(const Case& c, const std::string& name) {
  const auto found = std::find_if(c.boundaries.begin(), c.boundaries.end(),
                                  [&](const Boundary& b) { return b.name == name; });
  EXPECT_NE(found, c.boundaries.end()) << name;
  return *found;
}

/// Displacement of a motion table with linear interpolation from its first key to its last: the
/// trapezoid rule over each key interval, exact for a piecewise-linear velocity.
Eigen::Vector3d ramp_displacement(const Motion& motion) {
  Eigen::Vector3d d = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k + 1 < motion.keys.size(); ++k) {
    const MotionKey& a = motion.keys[k];
    const MotionKey& b = motion.keys[k + 1];
    d += 0.5 * (b.time - a.time) * (a.velocity + b.velocity);
  }
  return d;
}

/// Lowest and highest z of a .vtp file's points; with @p wall >= 0, only of the polygons whose
/// cell array wall_index is @p wall (a walls file holds every plane).
std::pair<double, double> z_range(const std::filesystem::path& path, int wall = -1) {
  const VtpContents contents = read_vtp(path.string());
  const VtpArray* index = contents.cell_array("wall_index");
  double lo = HUGE_VAL;
  double hi = -HUGE_VAL;
  for (std::size_t cell = 0; cell < contents.cells.size(); ++cell) {
    if (wall >= 0 && (index == nullptr || index->values[cell] != wall)) continue;
    for (const std::int64_t id : contents.cells[cell]) {
      const double z = contents.points[static_cast<std::size_t>(id)].z();
      lo = std::min(lo, z);
      hi = std::max(hi, z);
    }
  }
  return {lo, hi};
}

/// The particles' momentum along z [kg m/s] in a particles .vtp frame, all of density @p density.
double momentum_z(const std::filesystem::path& path, double density) {
  const VtpContents contents = read_vtp(path.string());
  const VtpArray* radius = contents.point_array("radius");
  const VtpArray* velocity = contents.point_array("velocity");
  EXPECT_TRUE(radius != nullptr && velocity != nullptr) << path;
  if (radius == nullptr || velocity == nullptr) return 0.0;
  double momentum = 0.0;
  for (std::size_t i = 0; i < radius->values.size(); ++i) {
    const double r = radius->values[i];
    momentum += density * 4.0 / 3.0 * std::numbers::pi * r * r * r * velocity->values[3 * i + 2];
  }
  return momentum;
}

std::filesystem::path frame_file(const std::filesystem::path& directory, const std::string& kind,
                                 int frame) {
  char name[64];
  std::snprintf(name, sizeof name, "%s_%06d.vtp", kind.c_str(), frame);
  return directory / name;
}

// Spreading with the profiled STL blade (cases/geometry/profiled_blade.stl at 1:5000, 0.4 mm wide
// and 1.2 mm tall, rounded edge leading) over a build platform that a motion table lowers by one
// layer (200 um) between the settling of the heap and the blade pass, with the blade's bottom
// edge fixed 50 um above the platform's starting height: a gap of 250 um.
TEST(MeshSpreading, PlatformLowersOneLayerAndTheStlBladeLeavesALayer) {
  // History every 10 us instead of the case's 0.2 ms: the loads are instantaneous values of a
  // rattling bed, and the means over the 4-5 ms phases of the lowering need hundreds of rows
  // (history rows do not change the run).
  const Case c =
      load_case(BONDEM_CASES_DIR "/powder_spreading_stl_ci.yaml", {"output.history_interval=1e-5"});
  const std::filesystem::path directory = testing::fresh_directory("mesh_spreading_stl");
  const RunResult r = testing::quiet_run(c, directory);
  const History history = read_history(directory / "history.csv");
  const Boundary& platform = boundary_named(c, "platform");
  const Boundary& blade = boundary_named(c, "blade");
  ASSERT_TRUE(c.layer.has_value());
  ASSERT_EQ(platform.motion.interpolation, MotionInterpolation::kLinear);
  ASSERT_EQ(platform.motion.keys.size(), 3u);
  const double blade_start = blade.motion.keys.back().time;
  const double weight = bed_weight(c);

  // The platform ends one layer lower, where the layer is measured from: its VTK outline (the
  // first plane of the walls files) at the last frame against the first. The stepper advances it
  // by dt x (the ramp at mid-step), exact for a linear ramp when the keys fall on steps (they do:
  // multiples of 1.25e-7 s); what is left is round-off: 8e4 additions of at most 5e-9 m to a
  // position below 2e-4 m (each rounded within 3e-20 m) and the step times' (1e-18 s each):
  // a few 1e-15 m, against a tolerance of 1e-13 m, a billionth of the drop.
  const double drop = ramp_displacement(platform.motion).z();
  EXPECT_NEAR(drop, c.layer->substrate_z - platform.center.z(), 1e-18);
  const int platform_plane = static_cast<int>(
      std::count_if(c.boundaries.begin(), c.boundaries.begin() + (&platform - c.boundaries.data()),
                    [](const Boundary& b) { return std::holds_alternative<PlaneShape>(b.shape); }));
  const int last_frame = static_cast<int>(std::lround(c.end_time / c.vtk_interval));
  const auto [platform_start, platform_start_top] =
      z_range(frame_file(directory, "walls", 0), platform_plane);
  const auto [platform_end, platform_end_top] =
      z_range(frame_file(directory, "walls", last_frame), platform_plane);
  EXPECT_EQ(platform_start, platform_start_top);  // horizontal
  EXPECT_EQ(platform_end, platform_end_top);
  EXPECT_NEAR(platform_end - platform_start, drop, 1e-13);
  EXPECT_NEAR(platform_end, c.layer->substrate_z, 1e-13);
  // The blade's bottom edge stays where it was: the gap is the drop plus the initial clearance.
  const double blade_bottom_start = z_range(frame_file(directory, "tools", 0)).first;
  const double blade_bottom_end = z_range(frame_file(directory, "tools", last_frame)).first;
  EXPECT_EQ(blade_bottom_end, blade_bottom_start);
  EXPECT_NEAR(blade_bottom_end - platform_end, c.layer->layer_height, 1e-13);

  // The loads balance the bed's momentum: between two VTK frames, the mean upward force of all
  // boundaries on the particles is W + (P_z(t2) - P_z(t1)) / (t2 - t1), with P_z the particles'
  // momentum from the frames' velocities (Newton for the whole bed; the heap is still slumping
  // before the lowering, which this accounts for). Windows of 4 ms from 8 ms (the heap has
  // landed) to 32 ms (the blade has started), through the lowering. The history rows are
  // instantaneous loads of a rattling bed (single rows range over 0-2.5 W), so their mean over a
  // window is uncertain by its standard error (rows 10 us apart, longer than a contact, taken as
  // independent): within 4 standard errors.
  const double g = c.gravity.norm();
  const double density = c.materials[static_cast<std::size_t>(c.particles[0].material)].density;
  const auto support_over = [&](double from, double to) {
    const std::vector<double> platform_z = history.values("load_platform_z", from, to);
    const std::vector<double> back_z = history.values("load_back_z", from, to);
    const std::vector<double> blade_z = history.values("load_blade_z", from, to);
    EXPECT_GT(platform_z.size(), 100u);
    std::vector<double> support(platform_z.size());
    for (std::size_t k = 0; k < support.size(); ++k) {
      support[k] = -(platform_z[k] + back_z[k] + blade_z[k]) / weight;
    }
    return mean_and_error(support);
  };
  for (int frame = 2; frame < 8; ++frame) {
    const double from = frame * c.vtk_interval;
    const double to = (frame + 1) * c.vtk_interval;
    const double change = momentum_z(frame_file(directory, "particles", frame + 1), density) -
                          momentum_z(frame_file(directory, "particles", frame), density);
    const MeanAndError held = support_over(from, to);
    const double expected = 1.0 + change / (to - from) / weight;
    EXPECT_NEAR(held.mean, expected, 4.0 * held.error) << "from " << from << " s to " << to;
    std::printf("[ %.3f-%.3f s ] support %.4f +- %.4f W, momentum balance %.4f W\n", from, to,
                held.mean, held.error, expected);
  }

  // The platform drives the bed: while it ramps, the bed rides it with its acceleration a and the
  // boundaries hold it up with W (1 + a / g) (the bed follows as long as a > -g; the table keeps
  // |a| at 8 m/s^2); at rest after the lowering, with W. Each window leaves out 0.5 ms after a
  // change of acceleration (the bed's response, tens of contact times). Within 4 standard errors
  // plus 0.04 W: the heap's own slump, which goes on through the lowering, adds up to 0.07 W
  // before it (the momentum balance above) and less as it dies out.
  const std::vector<MotionKey>& keys = platform.motion.keys;
  struct Window {
    const char* what;
    double from, to, acceleration;
  };
  const double down = (keys[1].velocity.z() - keys[0].velocity.z()) / (keys[1].time - keys[0].time);
  const double up = (keys[2].velocity.z() - keys[1].velocity.z()) / (keys[2].time - keys[1].time);
  const Window windows[] = {
      {"ramp down", keys[0].time + 5e-4, keys[1].time, down},
      {"ramp to rest", keys[1].time + 5e-4, keys[2].time, up},
      {"lowered, at rest", keys[2].time + 5e-4, blade_start, 0.0},
  };
  for (const Window& w : windows) {
    SCOPED_TRACE(w.what);
    const MeanAndError held = support_over(w.from, w.to);
    const double expected = 1.0 + w.acceleration / g;
    EXPECT_NEAR(held.mean, expected, 4.0 * held.error + 0.04);
    // The platform alone carries nearly all of it (the blade and the back wall a few per cent).
    const double platform_share =
        -mean_and_error(history.values("load_platform_z", w.from, w.to)).mean / weight;
    EXPECT_NEAR(platform_share, expected, 4.0 * held.error + 0.04 + 0.05);
    std::printf("[ %s ] support %.4f +- %.4f W (platform %.4f), expected %.4f\n", w.what, held.mean,
                held.error, platform_share, expected);
  }

  // The pass: the heap resists the blade. load_blade_x is the force of the powder on the blade,
  // so the blade pushes the powder with -load_blade_x > 0; its mean over the pass lies far above
  // its standard error.
  const MeanAndError push = mean_and_error(history.values("load_blade_x", blade_start, c.end_time));
  EXPECT_GT(-push.mean, 10.0 * push.error);
  EXPECT_GT(-push.mean, 0.1 * weight);
  // The mesh blade has its load and moment columns. The moment is about the blade's reference
  // point, the bottom centre of its profile: the powder pushes back (-x) on the face above it
  // and up (+z) under the rounded edge in front of it, and both turn the blade backwards about y.
  for (const char* axis : {"x", "y", "z"}) {
    for (const char* kind : {"load_blade_", "moment_blade_"}) {
      const std::vector<double> v = history.values(std::string(kind) + axis, 0.0, c.end_time);
      ASSERT_FALSE(v.empty());
      EXPECT_TRUE(std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); }));
    }
  }
  EXPECT_LT(mean_and_error(history.values("moment_blade_y", blade_start, c.end_time)).mean, 0.0);
  std::printf("[ pass ] push %.3g +- %.2g N (%.3f W)\n", -push.mean, push.error,
              -push.mean / weight);

  // The layer: a gap of 250 um (2.5 x D90) over a bare platform leaves a sparse layer, as the
  // box-blade case with the same gap does (0.21-0.24 over 5 seeds, tests/test_spreading.cpp),
  // within the band reported for such gaps (0.2-0.5) and well below random close packing.
  ASSERT_TRUE(r.layer.has_value());
  const LayerMetrics& layer = *r.layer;
  EXPECT_GT(layer.solid_fraction, 0.15);
  EXPECT_LT(layer.solid_fraction, 0.5);
  EXPECT_GT(layer.mean_surface_height, 50e-6);  // D10
  EXPECT_LT(layer.mean_surface_height, c.layer->layer_height);
  EXPECT_GT(layer.particles, 20u);
  std::printf(
      "[ layer ] solid fraction %.3f, mean height %.1f um, roughness %.1f um, bare %.3f, "
      "%zu particles, wall %.1f s\n",
      layer.solid_fraction, layer.mean_surface_height * 1e6, layer.roughness * 1e6,
      layer.empty_fraction, layer.particles, r.wall_seconds);
}

/// The drum's bed over the steady frames of one run.
struct DrumRun {
  Case c;
  RunResult r;
  std::vector<ReposeAngle> frames;  ///< angle of every VTK frame from steady_from on
  ReposeAngle final_state{};        ///< angle of final_state.csv
  double mean_degrees = 0.0;
  double mean_com_x = 0.0;       ///< mean over the frames of the bed's centre of mass along x
  double mean_moment_y = 0.0;    ///< mean of history's moment_drum_y over the steady rows
  MeanAndError support;          ///< -load_drum_z over the steady rows / weight
  double momentum_change = 0.0;  ///< the particles' z momentum, last frame minus first [kg m/s]
  double farthest_centre = 0.0;  ///< largest distance of a final centre from the axis
  double farthest_along = 0.0;   ///< largest |y| of a final centre plus its radius
  double weight = 0.0;
};

/// The repose angle of the particles (x, y, z, radius arrays) in @p drum about the y axis.
ReposeAngle drum_angle(const std::vector<double>& x, const std::vector<double>& y,
                       const std::vector<double>& z, const std::vector<double>& radius,
                       double drum_radius) {
  return dynamic_repose_angle(x, y, z, radius, Eigen::Vector3d::UnitY(), Eigen::Vector3d::Zero(),
                              drum_radius);
}

DrumRun drum_run(const std::string& name, const std::vector<std::string>& overrides,
                 double drum_radius, double steady_from) {
  DrumRun run;
  run.c = load_case(BONDEM_CASES_DIR "/rotating_drum_ci.yaml", overrides);
  const std::filesystem::path directory = testing::fresh_directory("mesh_drum_" + name);
  run.r = testing::quiet_run(run.c, directory);
  run.weight = bed_weight(run.c);
  const int last_frame = static_cast<int>(std::lround(run.c.end_time / run.c.vtk_interval));
  const int first_frame = static_cast<int>(std::lround(steady_from / run.c.vtk_interval));
  double sum_degrees = 0.0;
  for (int frame = first_frame; frame <= last_frame; ++frame) {
    const VtpContents v = read_vtp(frame_file(directory, "particles", frame).string());
    const VtpArray* radius = v.point_array("radius");
    EXPECT_NE(radius, nullptr);
    if (radius == nullptr) break;
    std::vector<double> x, y, z;
    double mass = 0.0;
    double moment = 0.0;
    for (std::size_t i = 0; i < v.points.size(); ++i) {
      x.push_back(v.points[i].x());
      y.push_back(v.points[i].y());
      z.push_back(v.points[i].z());
      const double r3 = radius->values[i] * radius->values[i] * radius->values[i];
      mass += r3;  // one material: the mass is proportional to r^3
      moment += r3 * v.points[i].x();
    }
    run.frames.push_back(drum_angle(x, y, z, radius->values, drum_radius));
    sum_degrees += run.frames.back().degrees;
    run.mean_com_x += moment / mass;
  }
  run.mean_degrees = sum_degrees / static_cast<double>(run.frames.size());
  run.mean_com_x /= static_cast<double>(run.frames.size());

  std::ifstream in(directory / "final_state.csv");
  std::string line;
  std::getline(in, line);  // id,x,y,z,vx,vy,vz,radius,material,wx,wy,wz
  std::vector<double> x, y, z, radius;
  while (std::getline(in, line)) {
    std::vector<double> v;
    std::stringstream fields(line);
    for (std::string field; v.size() < 8 && std::getline(fields, field, ',');) {
      v.push_back(std::stod(field));
    }
    x.push_back(v[1]);
    y.push_back(v[2]);
    z.push_back(v[3]);
    radius.push_back(v[7]);
    run.farthest_centre = std::max(run.farthest_centre, std::hypot(v[1], v[3]));
    run.farthest_along = std::max(run.farthest_along, std::abs(v[2]) + v[7]);
  }
  EXPECT_EQ(x.size(), run.c.particles.size());
  run.final_state = drum_angle(x, y, z, radius, drum_radius);

  const History history = read_history(directory / "history.csv");
  run.mean_moment_y =
      mean_and_error(history.values("moment_drum_y", steady_from, run.c.end_time)).mean;
  std::vector<double> support = history.values("load_drum_z", steady_from, run.c.end_time);
  for (double& value : support) value /= -run.weight;
  run.support = mean_and_error(support);
  const double density =
      run.c.materials[static_cast<std::size_t>(run.c.particles[0].material)].density;
  run.momentum_change = momentum_z(frame_file(directory, "particles", last_frame), density) -
                        momentum_z(frame_file(directory, "particles", first_frame), density);
  std::printf("[ drum %s ] mean %.2f deg over %zu frames (", name.c_str(), run.mean_degrees,
              run.frames.size());
  for (const ReposeAngle& a : run.frames) std::printf(" %.1f", a.degrees);
  std::printf(
      " ), final %.2f deg, slope %.3f, residual %.0f um, support %.4f +- %.4f W (momentum "
      "%.4f W), moment %.4g / W x_com %.4g, wall %.1f s\n",
      run.final_state.degrees, run.final_state.slope, run.final_state.residual * 1e6,
      run.support.mean, run.support.error,
      1.0 + run.momentum_change / (run.c.end_time - steady_from) / run.weight, run.mean_moment_y,
      run.weight * run.mean_com_x, run.r.wall_seconds);
  return run;
}

// The rotating drum (cases/geometry/drum.stl, inner radius 5 mm, 2 mm deep, at 1:1000) turning at
// 3 rad/s about +y after 50 ms of settling and a 50 ms ramp, to 0.7 s: 400 glass beads of
// 0.45-0.55 mm diameter, about a third full. Two runs, with and without friction between beads.
TEST(RotatingDrum, BedRollsAtAPlausibleAngleForItsFriction) {
  const Case c = load_case(BONDEM_CASES_DIR "/rotating_drum_ci.yaml");
  const Boundary& drum = boundary_named(c, "drum");
  const auto* mesh = std::get_if<MeshShape>(&drum.shape);
  ASSERT_NE(mesh, nullptr);
  // The drum's radius from its mesh: the farthest vertex from the axis (the 96-gon's corners).
  double drum_radius = 0.0;
  for (const Eigen::Vector3d& v : mesh->surface->mesh.vertices) {
    drum_radius = std::max(drum_radius, std::hypot(v.x(), v.z()));
  }
  EXPECT_NEAR(drum_radius, 5e-3, 1e-9);  // 5 mm in single precision (STL), scaled
  const double omega = drum.motion.keys.back().angular_velocity;
  // The rolling regime: Froude number omega^2 R / g within 1e-4 to 1e-2 (Mellmann 2001, Powder
  // Technol. 118:251-270): 4.6e-3.
  const double froude = omega * omega * drum_radius / c.gravity.norm();
  EXPECT_GT(froude, 1e-4);
  EXPECT_LT(froude, 1e-2);
  // The bed turns with the drum as a solid until its surface first fails (40-50 degrees, at
  // 0.3-0.4 s), then flows, swinging between about 35 and 45 degrees in avalanches some 0.2 s
  // apart (a small bed). The angle is the mean over the frames from 0.45 s to the end (0.7 s):
  // 11 frames, 25 ms (4 degrees of drum turn) apart, more than one avalanche cycle.
  const double steady_from = 0.45;
  const std::vector<std::string> frames{"output.vtk_interval=0.025",
                                        "output.history_interval=0.001"};
  const DrumRun rough = drum_run("friction", frames, drum_radius, steady_from);
  std::vector<std::string> smooth_overrides = frames;
  smooth_overrides.emplace_back("contact.friction=0");
  const DrumRun smooth = drum_run("frictionless", smooth_overrides, drum_radius, steady_from);

  for (const DrumRun* run : {&rough, &smooth}) {
    // No bead left the drum through the mesh: every centre is inside the shell, and every bead
    // between the end caps (at y = +-1 mm) but for its overlap with them (the largest overlap of
    // the run is about 3 um; 10 um allowed).
    EXPECT_LT(run->farthest_centre, drum_radius);
    EXPECT_LT(run->farthest_along, 1e-3 + 1e-5);
    // The bed's weight is carried by the drum: over the steady window the drum's mean upward
    // force is W + (P_z(end) - P_z(start)) / duration (Newton for the bed, P_z from the frames'
    // velocities), within 4 standard errors of the rows' mean (rows 1 ms apart through
    // avalanches)...
    const double duration = run->c.end_time - steady_from;
    EXPECT_NEAR(run->support.mean, 1.0 + run->momentum_change / duration / run->weight,
                4.0 * run->support.error);
    // ... and so is the moment of its weight about the axis: the bed's centre of mass sits on the
    // rising side (x < 0), and the drum holds it there against gravity. The bed pushes back on
    // the drum with the moment W x_com about +y (angular momentum balance of a bed whose own
    // angular momentum is steady), a negative, braking moment. Within 10 %: the centre of mass
    // is sampled in the 11 frames and the moment in the 250 history rows of the window, while the
    // surface swings by +-5 degrees between avalanches (x_com by a few per cent).
    EXPECT_LT(run->mean_com_x, 0.0);
    EXPECT_NEAR(run->mean_moment_y, run->weight * run->mean_com_x,
                0.1 * std::abs(run->weight * run->mean_com_x));
    // The surface is a line: it spans the binned band and the points scatter about it by less
    // than a bead diameter.
    for (const ReposeAngle& a : run->frames) {
      EXPECT_GE(a.bins_used, 15);
      EXPECT_LT(a.residual, 0.5e-3);
      // The drum turns positively about +y: its wall rises on the -x side, and the bed surface
      // rises with it (negative slope along the chord +x).
      EXPECT_LT(a.slope, 0.0);
    }
    EXPECT_LT(run->final_state.slope, 0.0);
  }
  // mu = 0.5 with rolling friction 0.05: DEM beds of frictional spheres in the rolling regime
  // lie at 30-45 degrees, measured as here by a line through the surface (Yang, Zou & Yu 2003,
  // Powder Technol. 130:138-146); the angle grows with sliding and rolling friction and with end
  // walls close together (Zhou, Xu, Yu & Zulli 2001, Phys. Rev. E 64:021301; Dury et al. 1998,
  // Phys. Rev. E 57:4491), and this drum is 4 bead diameters deep: 25-45 degrees. Measured 40
  // (the case's seed; 39 with another). The final state is one frame of the swing (34-50
  // degrees over seeds and frames).
  EXPECT_GT(rough.mean_degrees, 25.0);
  EXPECT_LT(rough.mean_degrees, 45.0);
  EXPECT_GT(rough.final_state.degrees, 25.0);
  EXPECT_LT(rough.final_state.degrees, 52.0);
  // Frictionless beads (the drum still grips them with 0.5): the bed is held only by the
  // packing's geometry and the end walls, and lies far flatter.
  EXPECT_LT(smooth.mean_degrees, rough.mean_degrees - 10.0);
  EXPECT_LT(smooth.mean_degrees, 0.6 * rough.mean_degrees);
}

}  // namespace
}  // namespace bondem
