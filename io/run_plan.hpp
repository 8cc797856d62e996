#pragma once
/// @file run_plan.hpp
/// What a run checks and prepares before its first step, shared by the run in one process
/// (run.hpp) and the distributed run (run_mpi.hpp): the plan of steps and outputs, the checkpoint
/// a restart continues, the output directory, and the messages of its ends.

#include <cstdint>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "io/checkpoint.hpp"
#include "io/run.hpp"
#include "solver/driver/run_analysis.hpp"
#include "solver/driver/simulation.hpp"
#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"
#include "solver/experiments/calculator.hpp"
#include "solver/setup/case.hpp"

namespace bondem {

/// What run_case checked and derived from the case and the options before writing anything.
struct RunPlan {
  TimeStepLimit limit;     ///< the case's time-step bound and what sets it
  std::int64_t steps = 0;  ///< the step at time.end
  std::int64_t history_every = 0;
  std::int64_t vtk_every = 0;
  std::int64_t checkpoint_every = 0;
  std::int64_t state_every = 0;  ///< 0: no state snapshots
  std::int64_t first_step = 0;   ///< the checkpoint's step on a restart, else 0
  std::filesystem::path directory;
  std::string checkpoint_path;
  std::uint64_t fingerprint = 0;
  bool restarting = false;
};

/// Check @p description's time step and step count against their limits, and derive the step
/// count, the output intervals and the output paths. Throws CaseError.
RunPlan plan_run(const Case& description, const RunOptions& options);

/// Throws CaseError when a checkpoint's @p fingerprint is not the plan's: it was written by
/// another case than @p description.
void check_checkpoint_fingerprint(std::uint64_t fingerprint, const Case& description,
                                  const RunOptions& options, const RunPlan& plan);

/// The checkpoint options.restart_path, checked to come from @p description, to fit @p scene (its
/// layout: the particles need not be there) and the case's @p case_particles particles, and to
/// end before the plan's last step; with @p rows, only those rows (read_checkpoint()). Its
/// pairs are streamed (CheckpointScope::pairs_streamed) to the Stepper its state restores.
/// Throws CaseError.
Checkpoint read_fitting_checkpoint(const Case& description, const RunOptions& options,
                                   const RunPlan& plan, const Scene& scene,
                                   std::size_t case_particles,
                                   const std::vector<std::uint64_t>* rows = nullptr);

/// Refuses, before any output is written, an output.history_fields name without a column in
/// this run, an output.vtk_fields name without a particle array, and a restart whose columns
/// differ from those of the history it continues (@p restored_history; empty for a fresh run).
void check_output_fields(const Case& description, const Scene& scene,
                         const std::string& restored_history);

/// An earlier run's outputs, moved aside under names of this process's temporaries and unlinked
/// on a thread of their own while the run goes on: ext4 frees a large file's blocks within the
/// unlink, waiting on the disk (0.1-0.3 s for a 10^6 run's checkpoint and final state, on the
/// critical path of every repeated run). The checkpoint and the final state, which the run writes
/// again under the same names, are offered for it to write over instead when large
/// (offer_for_rewrite); those it did not take are unlinked at the end. The destructor waits for
/// the thread, so a run ends with them gone; a process killed first leaves temporaries the next
/// run removes.
class StaleOutputRemoval {
 public:
  StaleOutputRemoval() = default;
  /// Starts unlinking @p moved; @p offered were offered for rewriting.
  explicit StaleOutputRemoval(std::vector<std::filesystem::path> moved,
                              std::vector<std::filesystem::path> offered = {});
  ~StaleOutputRemoval() { wait(); }
  StaleOutputRemoval(StaleOutputRemoval&& other) noexcept = default;
  StaleOutputRemoval& operator=(StaleOutputRemoval&& other) noexcept {
    wait();
    unlinking_ = std::move(other.unlinking_);
    offered_ = std::move(other.offered_);
    return *this;
  }
  StaleOutputRemoval(const StaleOutputRemoval&) = delete;
  StaleOutputRemoval& operator=(const StaleOutputRemoval&) = delete;

  /// Waits until every moved file is unlinked, and unlinks the offered ones not rewritten.
  void wait() noexcept;

 private:
  std::thread unlinking_;
  std::vector<std::filesystem::path> offered_;  ///< offered for rewriting
};

/// Make the output directory this run's, once everything is checked: probe that it can be
/// written, then remove what an earlier run left (as run_case() describes): moved aside at once,
/// unlinked while the returned removal lives (keep it for the run).
[[nodiscard]] StaleOutputRemoval prepare_output_directory(const Case& description,
                                                          const RunOptions& options,
                                                          const RunPlan& plan);

/// @p history (a checkpoint's history.csv text) without its last row when that row is the end
/// row of a finished run, at the checkpoint's @p step and @p time but off the grid of one row
/// every @p every steps: a run straight to a later end has no row there.
std::string history_without_end_row(const std::string& history, std::int64_t step, double time,
                                    std::int64_t every);

/// The command that continues an interrupted run: the one that started it, with its --restart
/// (if any) replaced by @p checkpoint_path.
std::string resume_command(const RunOptions& options, const Case& description,
                           const std::filesystem::path& directory,
                           const std::string& checkpoint_path);

/// The message of a blow-up report: @p e, the likely cause, and where the last good state is.
std::string blow_up_message(const BlowUpError& e, const Case& description, const RunPlan& plan);

/// The counts of a finished run that its result reports besides its figures.
struct RunCounts {
  std::size_t particles = 0;
  std::int64_t neighbor_builds = 0;
  ContactSummary contacts;  ///< of the last step
  std::int64_t bonds_formed = 0;
  std::int64_t bonds_broken = 0;
};

/// What a finished run reports: @p end, its @p counts, and the figures of its analysis.
RunResult collect_result(const RunEnd& end, const RunCounts& counts, const RunFigures& figures);

/// The same, with the counts of @p simulation.
RunResult collect_result(const RunEnd& end, const Simulation& simulation,
                         const RunFigures& figures);

}  // namespace bondem
