#pragma once
/// @file run.hpp
/// A whole run: case -> scene -> stepper, with the observers that write its outputs.

#include <cstdint>
#include <iosfwd>
#include <optional>
#include <string>

#include "solver/analysis.hpp"
#include "solver/case.hpp"
#include "solver/contact_kernel.hpp"

namespace bondem {

/// How to run (not what: that is the case).
struct RunOptions {
  std::string output_directory;  ///< overrides the case's output.directory when not empty
  bool quiet = false;            ///< no progress lines
};

/// What a finished run reports.
struct RunResult {
  std::int64_t steps = 0;
  std::size_t particles = 0;
  int threads = 1;
  double wall_seconds = 0.0;
  double particle_steps_per_second = 0.0;
  std::int64_t neighbor_builds = 0;
  ContactSummary contacts;  ///< at the end
  PackingReport packing;    ///< bed solid fraction and coordination at the end
  Box packing_region;
};

/// Run @p description to time.end, writing `history.csv` (time, kinetic energy, contacts, bonds,
/// wall contacts, largest overlap, at output.history_interval) and `final_state.csv` (one row per
/// particle sorted by id: id, x, y, z, vx, vy, vz, radius, 17 significant digits) into the output
/// directory. Progress goes to @p log. Throws CaseError when the time step exceeds the recommended
/// one, std::runtime_error when the run fails; no partial output file is left behind.
RunResult run_case(const Case& description, const RunOptions& options, std::ostream& log);

}  // namespace bondem
