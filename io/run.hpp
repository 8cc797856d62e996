#pragma once
/// @file run.hpp
/// A whole run: case -> scene -> stepper -> Simulation, with the observers that write its outputs
/// (io/run_observers.hpp) and measure its end (solver/driver/run_analysis.hpp).

#include <csignal>
#include <cstdint>
#include <iosfwd>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "solver/analysis/layer_metrics.hpp"
#include "solver/analysis/packing.hpp"
#include "solver/driver/run_analysis.hpp"
#include "solver/engine/contact_kernel.hpp"
#include "solver/setup/case.hpp"

namespace bondem {

/// How to run (not what: that is the case).
struct RunOptions {
  std::string output_directory;         ///< overrides the case's output.directory when not empty
  bool quiet = false;                   ///< no progress lines
  std::string restart_path;             ///< continue from this checkpoint when not empty
  bool enforce_time_step_limit = true;  ///< refuse a time step above case_time_step_limit()
  /// Set asynchronously (SIGINT, SIGTERM) to stop after the current step with a checkpoint.
  const volatile std::sig_atomic_t* stop_requested = nullptr;
  /// The command that started the run (argv), for the exact resume command; may be empty.
  std::vector<std::string> command_line;
};

/// The run stopped on request; checkpoint and outputs are written, the message says how to resume.
class RunInterrupted : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// What a finished run reports.
struct RunResult {
  std::int64_t steps = 0;
  std::size_t particles = 0;
  int threads = 1;  ///< threads the loops used (1 below kMinParallelParticles particles)
  double wall_seconds = 0.0;
  double particle_steps_per_second = 0.0;
  std::int64_t neighbor_builds = 0;
  ContactSummary contacts;  ///< at the end
  PackingReport packing;    ///< bed solid fraction and coordination at the end
  Box packing_region;
  std::optional<LayerMetrics> layer;  ///< spread layer, when the case asks for it
  std::size_t clusters = 0;           ///< bonded agglomerates of 2 or more (clusters.csv rows)
  std::size_t largest_cluster = 0;    ///< particles in the largest cluster (0 if none)
  std::size_t unbonded = 0;           ///< particles with no bond (in no cluster)
  SizeQuantiles primary_sizes;        ///< particle diameters
  SizeQuantiles cluster_sizes;        ///< volume-equivalent diameters of clusters of 2 or more
  std::int64_t bonds_formed = 0;      ///< over the whole run (restarts included)
  std::int64_t bonds_broken = 0;
  std::optional<ThermalReport> thermal;  ///< thermal runs only
};

/// Run @p description to time.end, writing into the output directory `history.csv` (time,
/// kinetic energy, contacts, bonds, wall contacts, largest overlap, at output.history_interval),
/// `final_state.csv` (one row per particle sorted by id: id, x, y, z, vx, vy, vz, radius, 17
/// significant digits) and `checkpoint.bin` (at output.checkpoint_interval and at the end).
/// With analysis.layer, also `layer.csv` (solid fraction per bin along x) and, always,
/// `clusters.csv` (bonded clusters: size and volume-equivalent diameter). Progress goes to @p log.
///
/// The run owns its output directory. Before step 0 it creates it and writes and removes a probe
/// file, then removes what an earlier run left: temporaries `<output>.tmp.<pid>` of processes no
/// longer running, and every file of the names above, `last_good_state.csv` and the VTK series
/// (`{particles,contacts,walls,tools}.pvd` and `_NNNNNN.vtp`). A restart keeps the checkpoint it
/// reads and the VTK frames an uninterrupted run has up to the checkpoint's time. Other files stay.
///
/// `history.csv` is appended and flushed row by row, so a run can be watched live; a restart
/// first rewrites it from the checkpoint. Whatever ends the run, it holds every row the run
/// produced (a blow-up's offending row excluded); a `checkpoint.bin` beside it may be older.
/// The end-of-run files are written checkpoint first, then `final_state.csv`, `clusters.csv`,
/// `layer.csv`, which are all removed if one of them fails: none appears without the checkpoint
/// of its state. Every other file is written atomically.
///
/// Throws CaseError (before writing anything) when the time step exceeds its limit, the step
/// count exceeds kMaxSteps, a restart checkpoint does not fit or ends after time.end, or the
/// output directory cannot be written; RunInterrupted when stopped on request (after writing the
/// checkpoint and the final state); BlowUpError (after writing `last_good_state.csv`) when the
/// physics blows up or a history value is not finite. The case is taken by value: its particle
/// list is freed once the scene holds the particles (move it in to save the memory).
RunResult run_case(Case description, const RunOptions& options, std::ostream& log);

}  // namespace bondem
