// Configurable output: output.history_fields chooses history.csv's columns, output.state_interval
// writes state_<n>.csv snapshots; both checked before anything is written, and kept by restarts.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "io/case_file.hpp"
#include "io/run.hpp"
#include "io/run_observers.hpp"
#include "io/vtk_output.hpp"
#include "run_helpers.hpp"

namespace bondem {
namespace {

namespace fs = std::filesystem;

/// The CI pouring case to @p end [s] with @p output appended to its `output:` block.
Case pouring(double end, const std::string& output) {
  std::ifstream in(BONDEM_CASES_DIR "/powder_pouring_ci.yaml");
  std::stringstream text;
  text << in.rdbuf() << output;
  return parse_case(text.str(), "pouring.yaml", {"time.end=" + std::to_string(end)});
}

std::string first_line(const fs::path& file) {
  std::istringstream in(testing::file_bytes(file));
  std::string line;
  std::getline(in, line);
  return line;
}

TEST(OutputOptions, HistoryFieldsChooseTheColumnsInTheirOrderAfterTime) {
  const fs::path directory = testing::fresh_directory("output_history_fields");
  testing::quiet_run(
      pouring(0.002, "  history_fields: [inserted, kinetic_energy, load_walls.0.z_min_z]\n"),
      directory);
  EXPECT_EQ(first_line(directory / "history.csv"),
            "time,inserted,kinetic_energy,load_walls.0.z_min_z");
}

TEST(OutputOptions, UnknownHistoryFieldIsRefusedWithItsLineBeforeAnyOutput) {
  const fs::path directory = testing::fresh_directory("output_history_unknown");
  try {
    testing::quiet_run(pouring(0.002, "  history_fields: [inserted, kinetic]\n"), directory);
    ADD_FAILURE() << "an unknown history column was accepted";
  } catch (const CaseError& e) {
    const std::string what = e.what();
    // The case file has 50 lines; the appended key is line 51.
    EXPECT_NE(what.find("pouring.yaml:51:"), std::string::npos) << what;
    EXPECT_NE(what.find("'output.history_fields': no history column 'kinetic'"), std::string::npos)
        << what;
    EXPECT_NE(what.find("kinetic_energy"), std::string::npos) << what;  // what there is
  }
  EXPECT_FALSE(fs::exists(directory));
}

TEST(OutputOptions, RestartKeepsTheHistoryColumns) {
  const fs::path directory = testing::fresh_directory("output_history_restart");
  testing::quiet_run(pouring(0.002, "  history_fields: [inserted]\n"), directory);
  try {
    testing::quiet_run(pouring(0.004, "  history_fields: [contacts]\n"), directory,
                       (directory / "checkpoint.bin").string());
    ADD_FAILURE() << "a restart with other history columns was accepted";
  } catch (const CaseError& e) {
    EXPECT_NE(std::string(e.what()).find("has other columns (time,inserted)"), std::string::npos)
        << e.what();
  }
  testing::quiet_run(pouring(0.004, "  history_fields: [inserted]\n"), directory,
                     (directory / "checkpoint.bin").string());
  EXPECT_EQ(first_line(directory / "history.csv"), "time,inserted");
}

TEST(OutputOptions, StateSnapshotsAreFinalStatesAtTheirStepsAndSurviveARestart) {
  const fs::path whole = testing::fresh_directory("output_states_whole");
  const fs::path resumed = testing::fresh_directory("output_states_resumed");
  const std::string every = "  state_interval: 0.002\n";
  testing::quiet_run(pouring(0.006, every), whole);
  // Snapshots at 0, 2, 4 and 6 ms; the last is the end, the same bytes as final_state.csv.
  for (int n = 0; n <= 3; ++n) EXPECT_TRUE(fs::exists(whole / state_file_name(n))) << n;
  EXPECT_FALSE(fs::exists(whole / state_file_name(4)));
  EXPECT_TRUE(testing::file_bytes(whole / state_file_name(3)) ==
              testing::file_bytes(whole / "final_state.csv"));
  // The particles poured so far: 100 by 2 ms (50 000/s), none at the start.
  EXPECT_EQ(first_line(whole / state_file_name(1)), "id,x,y,z,vx,vy,vz,radius,material,wx,wy,wz");
  std::istringstream second(testing::file_bytes(whole / state_file_name(1)));
  std::size_t rows = 0;
  for (std::string line; std::getline(second, line);) ++rows;
  EXPECT_EQ(rows, 101u);
  // A run stopped at 5 ms and continued writes the same snapshots.
  testing::quiet_run(pouring(0.005, every), resumed);
  testing::quiet_run(pouring(0.006, every), resumed, (resumed / "checkpoint.bin").string());
  for (int n = 0; n <= 3; ++n) {
    EXPECT_TRUE(testing::file_bytes(whole / state_file_name(n)) ==
                testing::file_bytes(resumed / state_file_name(n)))
        << n;
  }
  EXPECT_EQ(state_file_index("state_000012.csv"), 12);
  EXPECT_EQ(state_file_index("state_12.csv"), -1);
  EXPECT_EQ(state_file_index("final_state.csv"), -1);
}

TEST(OutputOptions, VtkFieldsChooseTheParticleArrays) {
  const fs::path directory = testing::fresh_directory("output_vtk_fields");
  testing::quiet_run(pouring(0.002,
                             "  vtk_interval: 0.001\n"
                             "  vtk_fields: [radius, velocity, coordination]\n"),
                     directory);
  // The array names are in the XML header of the file, its data appended after it.
  const std::string frame = testing::file_bytes(directory / "particles_000002.vtp");
  for (const char* kept : {"radius", "velocity", "coordination"}) {
    EXPECT_NE(frame.find(std::string("Name=\"") + kept + "\""), std::string::npos) << kept;
  }
  for (const char* left : {"force", "id", "material", "angular_velocity", "bond_count"}) {
    EXPECT_EQ(frame.find(std::string("Name=\"") + left + "\""), std::string::npos) << left;
  }
  try {
    testing::quiet_run(pouring(0.002, "  vtk_interval: 0.001\n  vtk_fields: [radius, speed]\n"),
                       testing::fresh_directory("output_vtk_unknown"));
    ADD_FAILURE() << "an unknown VTK array was accepted";
  } catch (const CaseError& e) {
    EXPECT_NE(std::string(e.what()).find("pouring.yaml:52:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no particle array 'speed'"), std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(fs::exists(testing::test_root() / "bondem_output_vtk_unknown"));
}

TEST(ParaViewOutput, FramesCarryTimeMaterialsLoadsDiametersAndForceVectors) {
  const fs::path directory = testing::fresh_directory("output_paraview");
  // At 20 ms the first spheres have landed: contacts with tangential forces.
  testing::quiet_run(pouring(0.02, "  vtk_interval: 0.01\n"), directory);
  const VtpContents frame = read_vtp((directory / "particles_000002.vtp").string());
  // ParaView's own name for a dataset's time.
  const VtpArray* time = nullptr;
  for (const VtpArray& a : frame.field_arrays) time = a.name == "TimeValue" ? &a : time;
  ASSERT_NE(time, nullptr);
  EXPECT_EQ(time->values, std::vector<double>{0.02});
  const VtpArray* diameter = frame.point_array("diameter");
  const VtpArray* radius = frame.point_array("radius");
  ASSERT_TRUE(diameter != nullptr && radius != nullptr);
  for (std::size_t i = 0; i < radius->values.size(); ++i) {
    EXPECT_EQ(diameter->values[i], 2.0 * radius->values[i]);
  }
  std::map<std::string, std::vector<std::string>> strings(frame.string_fields.begin(),
                                                          frame.string_fields.end());
  EXPECT_EQ(strings["material_names"], (std::vector<std::string>{"powder", "wall"}));
  // One load per boundary, the box's five faces, named as in history.csv.
  ASSERT_EQ(strings["boundary_names"].size(), 5u);
  EXPECT_EQ(strings["boundary_names"][4], "walls.0.z_min");
  const VtpArray* load = nullptr;
  for (const VtpArray& a : frame.field_arrays) load = a.name == "boundary_force" ? &a : load;
  ASSERT_NE(load, nullptr);
  EXPECT_EQ(load->values.size(), 15u);

  // A contact's normal and tangential vectors: along and across the line of centres.
  const VtpContents lines = read_vtp((directory / "contacts_000002.vtp").string());
  const VtpArray* normal = lines.cell_array("normal_force_vector");
  const VtpArray* tangential = lines.cell_array("tangential_force_vector");
  const VtpArray* magnitude = lines.cell_array("normal_force");
  ASSERT_TRUE(normal != nullptr && tangential != nullptr && magnitude != nullptr);
  ASSERT_GT(lines.lines, 0u);
  for (std::size_t k = 0; k < lines.lines; ++k) {
    const Eigen::Vector3d axis = (lines.points[2 * k + 1] - lines.points[2 * k]).normalized();
    const Eigen::Vector3d n(&normal->values[3 * k]);
    const Eigen::Vector3d t(&tangential->values[3 * k]);
    EXPECT_NEAR(n.dot(axis), magnitude->values[k], 1e-12 * std::abs(magnitude->values[k]));
    EXPECT_LE(std::abs(t.dot(axis)), 1e-9 * (t.norm() + n.norm()));
  }
  // A cold powder has no bonds series; the domain box is there once.
  EXPECT_FALSE(fs::exists(directory / "bonds.pvd"));
  EXPECT_EQ(read_vtp((directory / "domain.vtp").string()).lines, 12u);
}

TEST(ParaViewOutput, BondsAreASeriesOfTheirOwn) {
  // The paper's example 5.1: two spheres bond in a central collision at 2.6 m/s.
  const fs::path directory = testing::fresh_directory("output_bonds_series");
  testing::quiet_run(load_case(BONDEM_CASES_DIR "/paper_5_1.yaml",
                               {"output.vtk_interval=0.001", "time.end=0.002"}),
                     directory);
  ASSERT_TRUE(fs::exists(directory / "bonds.pvd"));
  EXPECT_EQ(read_vtp((directory / "bonds_000000.vtp").string()).lines, 0u);  // not yet touching
  const VtpContents bonded = read_vtp((directory / "bonds_000002.vtp").string());
  ASSERT_EQ(bonded.lines, 1u);
  EXPECT_EQ(bonded.cell_array("bonded")->values, std::vector<double>{1.0});
}

TEST(OutputOptions, NoEndOfRunFileAppearsWhenTheEndCheckpointFails) {
  // The end-of-run checkpoint is written on a thread of its own while the analysis and the
  // end-of-run files are made. Those must wait for it: when it fails (here its directory is a
  // file), none of them may appear, and the run must fail with the checkpoint's error.
  const fs::path directory = testing::fresh_directory("output_end_checkpoint_fails");
  fs::create_directories(directory);
  std::ofstream(directory / "a_file") << "not a directory\n";
  const Case c = load_case(BONDEM_CASES_DIR "/paper_5_1.yaml");
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  History history(scene, 1);
  CheckpointFile checkpoint((directory / "a_file" / "checkpoint.bin").string(), 0, 1000, history);
  RunAnalysis analysis(c);
  EndOfRunFiles end_files(directory, analysis, checkpoint);
  Simulation simulation(scene, stepper, 3);
  for (Observer* observer :
       std::initializer_list<Observer*>{&history, &checkpoint, &analysis, &end_files}) {
    simulation.attach(*observer);
  }
  try {
    simulation.run();
    ADD_FAILURE() << "the run ended although its checkpoint could not be written";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("checkpoint.bin"), std::string::npos) << error.what();
  }
  EXPECT_FALSE(fs::exists(directory / "final_state.csv"));
  EXPECT_FALSE(fs::exists(directory / "clusters.csv"));
}

}  // namespace
}  // namespace bondem
