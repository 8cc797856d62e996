// VTK XML output: frames read back with VTK's reader, .pvd collections, compression, failures.
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "io/vtk_output.hpp"
#include "run_helpers.hpp"

namespace bondem {
namespace {

namespace fs = std::filesystem;

constexpr std::size_t kParticles = 50;

/// (timestep, file) of every DataSet entry of a .pvd file, in file order.
std::vector<std::pair<double, std::string>> pvd_entries(const fs::path& path) {
  const std::string text = testing::file_bytes(path);
  EXPECT_NE(text.find("<VTKFile type=\"Collection\""), std::string::npos) << path;
  EXPECT_NE(text.find("</VTKFile>"), std::string::npos) << path;
  static const std::regex entry(R"re(<DataSet timestep="([^"]+)"[^>]*file="([^"]+)"\s*/>)re");
  std::vector<std::pair<double, std::string>> entries;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), entry);
       it != std::sregex_iterator(); ++it) {
    entries.emplace_back(std::stod((*it)[1].str()), (*it)[2].str());
  }
  return entries;
}

/// Files anywhere under @p root whose name marks them as temporaries.
std::vector<std::string> temporaries_under(const fs::path& root) {
  std::vector<std::string> found;
  if (!fs::exists(root)) return found;
  for (const fs::directory_entry& e : fs::recursive_directory_iterator(root)) {
    if (e.path().filename().string().find(".tmp.") != std::string::npos) {
      found.push_back(e.path().string());
    }
  }
  return found;
}

/// Distinct, non-round values so that an exact comparison means a bit-exact round trip.
Particles make_particles() {
  Particles p;
  for (std::size_t i = 0; i < kParticles; ++i) {
    const double k = static_cast<double>(i);
    const double position[3] = {1e-3 * std::sqrt(k + 1.0), 7e-4 * std::sin(k), 3e-4 * (k / 7.0)};
    const double velocity[3] = {std::cos(k), -k / 3.0, 1.0 / (k + 3.0)};
    p.add(1000 + 7 * static_cast<std::int64_t>(i), static_cast<std::int32_t>(i % 3),
          1e-4 * (1.0 + k / 97.0), 1e-9 * (1.0 + k), position, velocity);
  }
  p.track_displacement();
  return p;
}

void set_forces(Particles& p, int frame) {
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double k = static_cast<double>(i) + 0.1 * frame;
    p.fx[i] = 1e-6 * std::sin(k);
    p.fy[i] = -2e-6 * k / 11.0;
    p.fz[i] = 9.81e-9 * (1.0 + k);
  }
}

Domain make_domain() {
  Domain d;
  d.max = Eigen::Vector3d(0.01, 0.004, 0.005);
  return d;
}

/// The floor of the box and an oblique plane through it.
std::vector<Boundary> make_walls() {
  return {plane_boundary(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), 0, "box.z_min"),
          plane_boundary(Eigen::Vector3d(0.002, 0.0, 0.0),
                         Eigen::Vector3d(1.0, 0.0, 1.0).normalized(), 1, "slope")};
}

std::vector<ContactRecord> make_contacts(const Particles& p, int frame) {
  ContactRecord free_contact{p.id[3],
                             p.id[4],
                             Eigen::Vector3d(p.x[3], p.y[3], p.z[3]),
                             Eigen::Vector3d(p.x[4], p.y[4], p.z[4]),
                             1.25e-7 * (1 + frame),
                             -3.5e-3,
                             false};
  // A periodic image: the second end is where j is seen from i, not j's stored position.
  ContactRecord bond{p.id[10],
                     p.id[49],
                     Eigen::Vector3d(p.x[10], p.y[10], p.z[10]),
                     Eigen::Vector3d(p.x[10] + 1.9e-4, p.y[10], p.z[10] - 1e-5),
                     2.0e-8,
                     4.75e-4 / (1 + frame),
                     true};
  return {free_contact, bond};
}

class VtkOutput : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() /
            ("bondem_vtk_" +
             std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "_" +
             std::to_string(::getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_);
  }
  void TearDown() override {
    std::error_code ignored;
    fs::remove_all(root_, ignored);
  }

  fs::path root_;
};

TEST_F(VtkOutput, ThreeFramesReadBackExactly) {
  const fs::path dir = root_ / "out" / "vtk";  // missing parents are created too
  VtkSeriesWriter writer(dir.string());
  EXPECT_TRUE(fs::is_directory(dir));
  EXPECT_EQ(writer.frames(), 0u);

  Particles p = make_particles();
  const Domain domain = make_domain();
  const std::vector<Boundary> walls = make_walls();
  // Angular velocity and temperature are the particles' own fields (kParticleFields); the
  // coordination is a field derived per frame, passed by the caller.
  p.track_temperatures();
  std::vector<double> coordination(kParticles);
  const double times[3] = {0.0, 0.5e-3, 1e-3};
  for (int frame = 0; frame < 3; ++frame) {
    set_forces(p, frame);
    for (std::size_t i = 0; i < kParticles; ++i) {
      p.temperature[i] = 293.15 + 0.1 * static_cast<double>(i) + frame;
      p.wx[i] = 1.0 / (static_cast<double>(i) + 1.0);
      p.wy[i] = -static_cast<double>(frame);
      p.wz[i] = std::exp(-static_cast<double>(i));
      coordination[i] = static_cast<double>((i + static_cast<std::size_t>(frame)) % 7);
    }
    writer.write_frame(times[frame], p, make_contacts(p, frame), walls, domain,
                       {{"coordination", &coordination}});
    EXPECT_EQ(writer.frames(), static_cast<std::size_t>(frame + 1));

    // Each frame is complete on disk before the next one is written.
    char name[64];
    std::snprintf(name, sizeof name, "particles_%06d.vtp", frame);
    const VtpContents particles = read_vtp((dir / name).string());
    ASSERT_EQ(particles.points.size(), kParticles);
    EXPECT_EQ(particles.verts, kParticles);
    for (const char* array : {"id", "radius", "velocity", "force", "material", "coordination",
                              "temperature", "angular_velocity"}) {
      ASSERT_NE(particles.point_array(array), nullptr) << array;
      EXPECT_EQ(particles.point_array(array)->values.size() /
                    static_cast<std::size_t>(particles.point_array(array)->components),
                kParticles)
          << array;
    }
    EXPECT_EQ(particles.point_array("id")->type, "Int64");
    EXPECT_EQ(particles.point_array("material")->type, "Int32");
    EXPECT_EQ(particles.point_array("radius")->type, "Float64");
    EXPECT_EQ(particles.point_array("velocity")->components, 3);
    EXPECT_EQ(particles.point_array("force")->components, 3);
    EXPECT_EQ(particles.point_array("temperature")->components, 1);
    EXPECT_EQ(particles.point_array("angular_velocity")->components, 3);
    for (std::size_t i : {std::size_t{0}, std::size_t{17}, kParticles - 1}) {
      EXPECT_EQ(particles.points[i], Eigen::Vector3d(p.x[i], p.y[i], p.z[i])) << i;
      EXPECT_EQ(particles.point_array("id")->values[i], static_cast<double>(p.id[i]));
      EXPECT_EQ(particles.point_array("material")->values[i], p.material[i]);
      EXPECT_EQ(particles.point_array("radius")->values[i], p.radius[i]);
      const std::vector<double>& v = particles.point_array("velocity")->values;
      EXPECT_EQ(v[3 * i], p.vx[i]);
      EXPECT_EQ(v[3 * i + 1], p.vy[i]);
      EXPECT_EQ(v[3 * i + 2], p.vz[i]);
      const std::vector<double>& f = particles.point_array("force")->values;
      EXPECT_EQ(f[3 * i], p.fx[i]);
      EXPECT_EQ(f[3 * i + 1], p.fy[i]);
      EXPECT_EQ(f[3 * i + 2], p.fz[i]);
      EXPECT_EQ(particles.point_array("temperature")->values[i], p.temperature[i]);
      EXPECT_EQ(particles.point_array("coordination")->values[i], coordination[i]);
      const std::vector<double>& w = particles.point_array("angular_velocity")->values;
      EXPECT_EQ(w[3 * i], p.wx[i]);
      EXPECT_EQ(w[3 * i + 1], p.wy[i]);
      EXPECT_EQ(w[3 * i + 2], p.wz[i]);
    }

    std::snprintf(name, sizeof name, "contacts_%06d.vtp", frame);
    const VtpContents contacts = read_vtp((dir / name).string());
    const std::vector<ContactRecord> expected = make_contacts(p, frame);
    ASSERT_EQ(contacts.lines, 2u);
    ASSERT_EQ(contacts.cells.size(), 2u);
    for (const char* array : {"overlap", "normal_force", "bonded", "id_i", "id_j"}) {
      ASSERT_NE(contacts.cell_array(array), nullptr) << array;
      EXPECT_EQ(contacts.cell_array(array)->values.size(), 2u) << array;
    }
    EXPECT_EQ(contacts.cell_array("bonded")->type, "UInt8");
    EXPECT_EQ(contacts.cell_array("id_i")->type, "Int64");
    for (std::size_t k = 0; k < 2; ++k) {
      ASSERT_EQ(contacts.cells[k].size(), 2u);
      EXPECT_EQ(contacts.points[static_cast<std::size_t>(contacts.cells[k][0])],
                expected[k].first_position);
      EXPECT_EQ(contacts.points[static_cast<std::size_t>(contacts.cells[k][1])],
                expected[k].second_position);
      EXPECT_EQ(contacts.cell_array("overlap")->values[k], expected[k].overlap);
      EXPECT_EQ(contacts.cell_array("normal_force")->values[k], expected[k].normal_force);
      EXPECT_EQ(contacts.cell_array("bonded")->values[k], expected[k].bonded ? 1.0 : 0.0);
      EXPECT_EQ(contacts.cell_array("id_i")->values[k], static_cast<double>(expected[k].id_i));
      EXPECT_EQ(contacts.cell_array("id_j")->values[k], static_cast<double>(expected[k].id_j));
    }
  }

  // Static walls: one file, referenced by every frame.
  EXPECT_TRUE(fs::exists(dir / "walls_000000.vtp"));
  EXPECT_FALSE(fs::exists(dir / "walls_000001.vtp"));
  const VtpContents wall_data = read_vtp((dir / "walls_000000.vtp").string());
  ASSERT_EQ(wall_data.polys, 2u);
  ASSERT_NE(wall_data.cell_array("wall_index"), nullptr);
  EXPECT_EQ(wall_data.cell_array("wall_index")->values, (std::vector<double>{0.0, 1.0}));
  EXPECT_EQ(wall_data.cell_array("material")->values, (std::vector<double>{0.0, 1.0}));
  // The floor is exactly the domain's bottom face, counter-clockwise seen from inside.
  std::vector<Eigen::Vector3d> floor;
  for (std::int64_t id : wall_data.cells[0])
    floor.push_back(wall_data.points[static_cast<std::size_t>(id)]);
  ASSERT_EQ(floor.size(), 4u);
  const Eigen::Vector3d corners[4] = {
      {0.0, 0.0, 0.0}, {0.01, 0.0, 0.0}, {0.01, 0.004, 0.0}, {0.0, 0.004, 0.0}};
  for (const Eigen::Vector3d& corner : corners) {
    EXPECT_EQ(std::count(floor.begin(), floor.end(), corner), 1) << corner.transpose();
  }
  EXPECT_GT((floor[1] - floor[0]).cross(floor[2] - floor[1]).z(), 0.0);
  // The slope is clipped to the box and lies on its plane.
  const double tolerance = 1e-12 * domain.length().norm();
  for (std::int64_t id : wall_data.cells[1]) {
    const Eigen::Vector3d& q = wall_data.points[static_cast<std::size_t>(id)];
    EXPECT_NEAR(nearest_surface(walls[1], q).gap, 0.0, tolerance);
    for (int a = 0; a < 3; ++a) {
      EXPECT_GE(q[a], domain.min[a] - tolerance);
      EXPECT_LE(q[a], domain.max[a] + tolerance);
    }
  }

  // Every collection lists the three frames with their exact times; every file reads back.
  for (const char* series : {"particles", "contacts", "walls"}) {
    const auto entries = pvd_entries(dir / (std::string(series) + ".pvd"));
    ASSERT_EQ(entries.size(), 3u) << series;
    for (int frame = 0; frame < 3; ++frame) {
      const auto& [time, file] = entries[static_cast<std::size_t>(frame)];
      EXPECT_EQ(time, times[frame]) << series;
      char name[64];
      std::snprintf(name, sizeof name, "%s_%06d.vtp", series,
                    std::string(series) == "walls" ? 0 : frame);
      EXPECT_EQ(file, name);  // relative to the .pvd's directory
      EXPECT_NO_THROW(read_vtp((dir / file).string())) << file;
    }
  }
  EXPECT_TRUE(temporaries_under(root_).empty());
}

// Two writers on one directory, each writing its piece of every frame, as the processes of a
// distributed run do: VTK's parallel reader opens the .pvtp as the whole set; a frame is listed
// only once published; a restart on one process continues the series with whole frames.
TEST_F(VtkOutput, PiecesReadBackAsOneDataSetThroughTheSummary) {
  const Particles p = make_particles();
  std::vector<std::uint32_t> even, odd;
  for (std::uint32_t i = 0; i < p.size(); ++i) (i % 2 == 0 ? even : odd).push_back(i);
  const Particles halves[2] = {p.selected(even), p.selected(odd)};
  const std::vector<ContactRecord> contacts = make_contacts(p, 0);
  const Domain domain = make_domain();
  const std::vector<Boundary> walls = make_walls();
  VtkSeriesWriter first(root_.string()), second(root_.string());
  first.set_pieces(0, 2);
  second.set_pieces(1, 2);
  for (int frame = 0; frame < 2; ++frame) {
    const double time = 1e-3 * frame;
    first.write_frame(time, halves[0], {contacts[0]}, walls, domain);
    second.write_frame(time, halves[1], {contacts[1]}, walls, domain);
    // Written, not listed: the .pvd waits for publish().
    if (frame == 0) {
      EXPECT_FALSE(fs::exists(root_ / "particles.pvd"));
    } else {
      EXPECT_EQ(pvd_entries(root_ / "particles.pvd").size(), 1u);
    }
    first.publish();
    second.publish();  // not piece 0's: does nothing
  }
  const auto listed = pvd_entries(root_ / "particles.pvd");
  ASSERT_EQ(listed.size(), 2u);
  EXPECT_EQ(listed[1].second, "particles_000001.pvtp");
  EXPECT_TRUE(fs::exists(root_ / "particles_000001_1.vtp"));
  EXPECT_FALSE(fs::exists(root_ / "particles_000001.vtp"));

  const VtpContents whole = read_vtp((root_ / "particles_000001.pvtp").string());
  ASSERT_EQ(whole.points.size(), p.size());
  const VtpArray* id = whole.point_array("id");
  ASSERT_NE(id, nullptr);
  // Each piece by id, piece after piece: every particle once, at its own position.
  for (std::size_t k = 0; k < p.size(); ++k) {
    const std::size_t i = k < even.size() ? even[k] : odd[k - even.size()];
    EXPECT_EQ(id->values[k], static_cast<double>(p.id[i]));
    EXPECT_EQ(whole.points[k], Eigen::Vector3d(p.x[i], p.y[i], p.z[i]));
  }
  const VtpContents lines = read_vtp((root_ / "contacts_000001.pvtp").string());
  ASSERT_EQ(lines.lines, 2u);
  EXPECT_EQ(lines.cell_array("id_j")->values[1], static_cast<double>(contacts[1].id_j));

  // Continued on one process: the pieces stay listed, the next frame is whole.
  VtkSeriesWriter alone(root_.string());
  alone.resume([](double) { return true; }, walls, domain);
  alone.write_frame(2e-3, p, contacts, walls, domain);
  const auto continued = pvd_entries(root_ / "particles.pvd");
  ASSERT_EQ(continued.size(), 3u);
  EXPECT_EQ(continued[1].second, "particles_000001.pvtp");
  EXPECT_EQ(continued[2].second, "particles_000002.vtp");
}

TEST_F(VtkOutput, FilesAreBinaryAppendedAndZlibCompressed) {
  VtkSeriesWriter writer(root_.string());
  Particles p = make_particles();
  set_forces(p, 0);
  writer.write_frame(0.0, p, make_contacts(p, 0), make_walls(), make_domain());
  for (const char* file : {"particles_000000.vtp", "contacts_000000.vtp", "walls_000000.vtp"}) {
    const std::string text = testing::file_bytes(root_ / file);
    const std::string header = text.substr(0, text.find("<AppendedData"));
    EXPECT_NE(header.find("compressor=\"vtkZLibDataCompressor\""), std::string::npos) << file;
    EXPECT_NE(header.find("format=\"appended\""), std::string::npos) << file;
    EXPECT_EQ(header.find("format=\"ascii\""), std::string::npos) << file;
    EXPECT_NE(text.find("<AppendedData encoding=\"raw\">"), std::string::npos) << file;
  }
}

TEST_F(VtkOutput, MovedWallGetsNewFileAndEveryFrameAnEntry) {
  VtkSeriesWriter writer(root_.string());
  Particles p = make_particles();
  std::vector<Boundary> walls = make_walls();
  const Domain domain = make_domain();
  writer.write_frame(0.0, p, {}, walls, domain);
  walls[0].center.z() = 1e-3;  // the floor rises
  writer.write_frame(1e-4, p, {}, walls, domain);
  writer.write_frame(2e-4, p, {}, walls, domain);
  const auto entries = pvd_entries(root_ / "walls.pvd");
  ASSERT_EQ(entries.size(), 3u);
  EXPECT_EQ(entries[0].second, "walls_000000.vtp");
  EXPECT_EQ(entries[1].second, "walls_000001.vtp");
  EXPECT_EQ(entries[2].second, "walls_000001.vtp");
  EXPECT_FALSE(fs::exists(root_ / "walls_000002.vtp"));
  const VtpContents moved = read_vtp((root_ / "walls_000001.vtp").string());
  for (std::int64_t id : moved.cells[0]) {
    EXPECT_EQ(moved.points[static_cast<std::size_t>(id)].z(), 1e-3);
  }
  // A frame without contacts is an empty but valid file.
  EXPECT_EQ(read_vtp((root_ / "contacts_000002.vtp").string()).lines, 0u);
}

TEST_F(VtkOutput, MovingPlaneIsDrawnEveryFrameAndAMeshAtItsPose) {
  VtkSeriesWriter writer(root_.string());
  Particles p = make_particles();
  std::vector<Boundary> boundaries = make_walls();
  // The floor is a platform with a motion: drawn every frame, even where it has not moved yet.
  boundaries[0].motion.keys = {{1.0, Eigen::Vector3d(0.0, 0.0, -0.1)}};
  // A two-triangle square, its reference point at its centre, turned by 30 degrees about z and
  // carried 1 mm along x.
  TriangleMesh square;
  square.vertices = {
      {0.001, 0.001, 0.002}, {0.003, 0.001, 0.002}, {0.003, 0.003, 0.002}, {0.001, 0.003, 0.002}};
  square.triangles = {{0, 1, 2}, {0, 2, 3}};
  const Eigen::Vector3d pivot(0.002, 0.002, 0.002);
  Boundary mesh = mesh_boundary(square, pivot, 1, "plate");
  mesh.motion.axis = Eigen::Vector3d::UnitZ();
  mesh.motion.spin = 1.0;
  mesh.angle = std::numbers::pi / 6.0;
  mesh.center = pivot + Eigen::Vector3d(0.001, 0.0, 0.0);
  boundaries.push_back(mesh);
  const Domain domain = make_domain();
  writer.write_frame(0.0, p, {}, boundaries, domain);
  writer.write_frame(1e-4, p, {}, boundaries, domain);
  const auto entries = pvd_entries(root_ / "walls.pvd");
  ASSERT_EQ(entries.size(), 2u);
  EXPECT_EQ(entries[1].second, "walls_000001.vtp");
  const VtpContents tools = read_vtp((root_ / "tools_000001.vtp").string());
  EXPECT_EQ(tools.polys, 2u);
  ASSERT_EQ(tools.points.size(), 4u);
  const Eigen::Matrix3d turn =
      Eigen::AngleAxisd(std::numbers::pi / 6.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  for (std::size_t v = 0; v < 4; ++v) {
    const Eigen::Vector3d expected = mesh.center + turn * (square.vertices[v] - pivot);
    EXPECT_LT((tools.points[v] - expected).norm(), 1e-15) << v;
  }
  EXPECT_EQ(tools.cell_array("material")->values, std::vector<double>({1.0, 1.0}));
}

TEST_F(VtkOutput, UncreatableDirectoryThrowsAndLeavesNothing) {
  const fs::path blocker = root_ / "regular_file";
  std::ofstream(blocker) << "not a directory";
  EXPECT_THROW(VtkSeriesWriter((blocker / "vtk").string()), std::runtime_error);
  std::vector<fs::path> left;
  for (const fs::directory_entry& e : fs::directory_iterator(root_)) left.push_back(e.path());
  EXPECT_EQ(left, std::vector<fs::path>{blocker});
}

TEST_F(VtkOutput, WriteFailureNamesTheFileAndLeavesNoTemporary) {
  const fs::path dir = root_ / "vtk";
  VtkSeriesWriter writer(dir.string());
  Particles p = make_particles();
  // The directory disappears under the writer (a regular file takes its name).
  fs::remove_all(dir);
  std::ofstream(dir) << "not a directory";
  try {
    writer.write_frame(0.0, p, {}, make_walls(), make_domain());
    FAIL() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("particles_000000.vtp"), std::string::npos) << e.what();
  }
  EXPECT_EQ(writer.frames(), 0u);
  EXPECT_TRUE(temporaries_under(root_).empty());
}

TEST_F(VtkOutput, FailedCollectionIsRolledBack) {
  VtkSeriesWriter writer(root_.string());
  Particles p = make_particles();
  // A directory in the way of contacts.pvd: the rename onto it fails.
  fs::create_directories(root_ / "contacts.pvd" / "occupied");
  EXPECT_THROW(writer.write_frame(0.0, p, {}, make_walls(), make_domain()), std::runtime_error);
  EXPECT_EQ(writer.frames(), 0u);
  EXPECT_TRUE(temporaries_under(root_).empty());
  // Once the obstacle is gone the same frame goes through and every collection lists it once.
  fs::remove_all(root_ / "contacts.pvd");
  writer.write_frame(0.0, p, {}, make_walls(), make_domain());
  EXPECT_EQ(writer.frames(), 1u);
  for (const char* series : {"particles.pvd", "contacts.pvd", "walls.pvd"}) {
    EXPECT_EQ(pvd_entries(root_ / series).size(), 1u) << series;
  }
}

/// make_particles() with temperatures, as a thermal run has them.
Particles thermal_particles() {
  Particles p = make_particles();
  p.track_temperatures();
  for (StaggeredVector<double>* field :
       {&p.temperature, &p.peak_temperature, &p.inv_heat_capacity, &p.heat_rate}) {
    for (std::size_t i = 0; i < kParticles; ++i) field->at(i) = 300.0 + static_cast<double>(i);
  }
  return p;
}

// The particle file's arrays come from kParticleFields in their VTK order, with the caller's
// derived arrays at their places: the order every file of earlier versions has.
TEST_F(VtkOutput, ParticleArraysFollowTheFieldTable) {
  const Particles p = thermal_particles();
  const std::vector<double> coordination(kParticles, 2.0), bond_count(kParticles, 1.0);
  VtkSeriesWriter writer((root_ / "vtk").string());
  writer.write_frame(0.0, p, {}, {}, make_domain(),
                     {{"coordination", &coordination}, {"bond_count", &bond_count}});
  const VtpContents file = read_vtp((root_ / "vtk" / "particles_000000.vtp").string());
  std::vector<std::string> names;
  for (const VtpArray& array : file.point_arrays) names.push_back(array.name);
  const std::vector<std::string> expected = {"id",          "radius",           "velocity",
                                             "force",       "material",         "coordination",
                                             "bond_count",  "temperature",      "peak_temperature",
                                             "heat_rate",   "angular_velocity", "torque",
                                             "displacement"};
  EXPECT_EQ(names, expected);
  EXPECT_EQ(file.point_array("torque")->components, 3);
  EXPECT_EQ(file.point_array("heat_rate")->values[4], p.heat_rate[4]);

  // Without temperatures the thermal arrays are absent.
  VtkSeriesWriter plain_writer((root_ / "plain").string());
  plain_writer.write_frame(0.0, make_particles(), {}, {}, make_domain());
  const VtpContents plain = read_vtp((root_ / "plain" / "particles_000000.vtp").string());
  EXPECT_EQ(plain.point_array("temperature"), nullptr);
  EXPECT_NE(plain.point_array("angular_velocity"), nullptr);
}

// A caller that still passes the particles' own fields (as the run's VTK observer did before the
// table) gets the same bytes as one that passes only its derived arrays.
TEST_F(VtkOutput, ExtraFieldUnderAParticleFieldNameIsRefused) {
  // The particles' own fields are written from their table; an extra array under one of their
  // names would make ParaView show only one of the two.
  const Particles p = thermal_particles();
  VtkSeriesWriter writer((root_ / "vtk").string());
  const std::vector<double> other(kParticles, 0.0);
  EXPECT_THROW(writer.write_frame(0.0, p, {}, {}, make_domain(), {{"temperature", &other}}),
               std::invalid_argument);
  EXPECT_THROW(
      writer.write_frame(0.0, p, {}, {}, make_domain(), {}, {{"torque", &p.wx, &p.wy, &p.wz}}),
      std::invalid_argument);
  EXPECT_EQ(writer.frames(), 0u);
}

TEST_F(VtkOutput, RejectsBadInputBeforeWriting) {
  const fs::path dir = root_ / "vtk";
  VtkSeriesWriter writer(dir.string());
  Particles p = make_particles();
  std::vector<double> short_field(kParticles - 1, 0.0);
  EXPECT_THROW(writer.write_frame(0.0, p, {}, {}, make_domain(), {{"temperature", &short_field}}),
               std::invalid_argument);
  std::vector<double> full(kParticles, 0.0);
  EXPECT_THROW(writer.write_frame(0.0, p, {}, {}, make_domain(), {{"radius", &full}}),
               std::invalid_argument);
  EXPECT_TRUE(fs::is_empty(dir));
  writer.write_frame(1e-3, p, {}, {}, make_domain());
  EXPECT_THROW(writer.write_frame(1e-3, p, {}, {}, make_domain()), std::invalid_argument);
  EXPECT_THROW(writer.write_frame(std::nan(""), p, {}, {}, make_domain()), std::invalid_argument);
  EXPECT_EQ(writer.frames(), 1u);
}

}  // namespace
}  // namespace bondem
