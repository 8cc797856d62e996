#pragma once
/// @file run_observers.hpp
/// The observers of a run that write its files: history.csv, last_good_state.csv, the VTK series,
/// checkpoint.bin and the end-of-run files.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <future>
#include <string>
#include <string_view>
#include <vector>

#include "io/vtk_output.hpp"
#include "solver/driver/history.hpp"
#include "solver/driver/run_analysis.hpp"
#include "solver/driver/simulation.hpp"

namespace bondem {

/// One row per particle sorted by id (id, x, y, z, vx, vy, vz, radius, 17 significant digits),
/// written atomically to @p path; with @p bonds (one count per particle) a thermal set adds
/// temperature, peak_temperature and bonds; then the material by its name in
/// @p material_names and the angular velocity wx, wy, wz: a complete state that a case can start
/// from (`initial_state:`).
void write_final_state(const Particles& p, const std::vector<std::string>& material_names,
                       const std::string& path, const std::vector<int>& bonds = {});

/// The end-of-run files of @p figures and the final state @p p (with @p bonds as
/// write_final_state()) in @p directory: final_state.csv, clusters.csv and, with a layer,
/// layer.csv; all of them or, on an error, none. @p before_commit (when given) runs once the
/// files are written and before the first of them appears: an error it throws leaves none.
void write_end_of_run_files(const std::filesystem::path& directory, const Particles& p,
                            const std::vector<std::string>& material_names,
                            const std::vector<int>& bonds, const RunFigures& figures,
                            const std::function<void()>& before_commit = {});

/// history.csv, live: truncated when opened, then appended and flushed piece by piece, so that a
/// run can be watched (and plotted) while it runs. Feed it as History's sink.
class HistoryFile {
 public:
  explicit HistoryFile(std::string path);
  /// Append @p text and flush. Throws std::runtime_error naming the file on a write failure.
  void append(const std::string& text);

 private:
  std::string path_;
  std::ofstream stream_;
};

/// Name, before its tag and `.tmp.<pid>`, of a LastGoodFile's scratch file in the output
/// directory.
inline constexpr std::string_view kLastGoodScratch = ".bondem_last_good";

/// The last state known to be sound (positions, velocities, radii, ids): the state of the
/// history's latest row, or the state at construction before the first. Written to @p path when
/// the run blows up. Kept on disk, not in memory: at each such state the kLastGood fields are
/// written, raw and in the particles' current order, over a scratch file in @p path's directory
/// that is unlinked as soon as it is opened (so nothing is left behind, even after a SIGKILL), and
/// read back only on a blow-up. That saves 64 B a particle of resident memory for one write of as
/// many bytes per history row but the last, through a FileWriteBuffer, past the page cache (at
/// 10^6 particles the first write and the first step took 0.25 s by their median into fresh
/// page-cache pages, 0.15 s so).
class LastGoodFile : public Observer {
 public:
  /// Throws std::runtime_error when the scratch file cannot be opened or written. @p scratch_tag
  /// goes into the scratch file's name: processes of a distributed run on several machines may
  /// share a process id, not a rank.
  LastGoodFile(std::string path, const Particles& particles, const History& history,
               const std::string& scratch_tag = "");
  ~LastGoodFile() override;
  LastGoodFile(const LastGoodFile&) = delete;
  LastGoodFile& operator=(const LastGoodFile&) = delete;
  void after_step(const Simulation& simulation) override;
  /// At the history's rows.
  bool reads_state(const Simulation& simulation, std::int64_t step) const override {
    return history_.reads_state(simulation, step);
  }
  void interrupted(const Simulation& simulation, const Interruption& why) override;

  /// Write the kLastGood fields of @p particles over the scratch file, of the rows @p rows in
  /// that order (nullptr: every row). A distributed run keeps each process's own particles.
  void keep(const Particles& particles, const std::vector<std::uint32_t>* rows = nullptr);
  /// The state last kept (only its kLastGood fields).
  Particles kept();

 private:
  std::string path_;
  const History& history_;
  int scratch_ = -1;  ///< descriptor of the scratch file: open, unlinked
};

/// What a VTK frame derives from @p stepper's last force evaluation of @p scene: each particle's
/// coordination and bond count (pairs at positive overlap, bonded ones), and each such pair as a
/// record, seen from its smaller id, passed to @p contact with the row of that particle.
void frame_contacts(const Scene& scene, const Stepper& stepper, std::vector<double>& coordination,
                    std::vector<double>& bond_count,
                    const std::function<void(std::size_t, const ContactRecord&)>& contact);

/// VTK frames (particles with coordination and bond count, contacts, walls, tools) at step 0,
/// every @p every steps and at the end, plus one at a stop request off that grid (a restart drops
/// it).
class VtkFrames : public Observer {
 public:
  /// The arrays it derives per frame besides the particles' own fields.
  static const std::vector<std::string>& derived_arrays();

  /// Frames into @p directory; @p fields: the particle arrays to write (empty: all).
  VtkFrames(const std::filesystem::path& directory, std::int64_t every,
            std::vector<std::string> fields = {});

  /// Continue the series of an interrupted run from the checkpoint at @p checkpoint_step: keep
  /// the frames an uninterrupted run writes up to it, drop the rest (the frame written at an
  /// interruption, frames past the checkpoint).
  void resume(const Scene& scene, std::int64_t checkpoint_step, double time_step);

  void start(const Simulation& simulation) override;
  void after_step(const Simulation& simulation) override;
  /// At its frames' steps.
  bool reads_state(const Simulation& simulation, std::int64_t step) const override {
    return every_or_last(simulation, step, every_);
  }
  void interrupted(const Simulation& simulation, const Interruption& why) override;

 private:
  void write(const Scene& scene, const Stepper& stepper);
  /// Give the writer what the scene says of every frame: material names, a bonds series.
  void describe(const Scene& scene);

  std::int64_t every_;
  VtkSeriesWriter writer_;
  std::vector<double> coordination_, bond_count_, diameter_;
  std::vector<ContactRecord> contacts_;
};

/// Name of state snapshot @p index: state_000012.csv.
std::string state_file_name(std::int64_t index);

/// The index of a state snapshot's file name, or -1 for another name.
std::int64_t state_file_index(const std::string& name);

/// state_<n>.csv, in the format of final_state.csv, at step 0 and every @p every steps after:
/// snapshot n is of step n * every (a restart keeps the ones up to its checkpoint).
class StateFiles : public Observer {
 public:
  StateFiles(std::filesystem::path directory, std::int64_t every);
  void start(const Simulation& simulation) override;
  void after_step(const Simulation& simulation) override;
  /// At its snapshots' steps.
  bool reads_state(const Simulation& /*simulation*/, std::int64_t step) const override {
    return step % every_ == 0;
  }

 private:
  void write(const Simulation& simulation) const;
  std::filesystem::path directory_;
  std::int64_t every_;
};

/// Name of the profile file of layer @p number (from 1) of analysis.layers: layer_001.csv.
std::string layer_file_name(std::int64_t number);

/// The layer number of a layer file's name, or -1 for another name.
std::int64_t layer_file_number(const std::string& name);

/// The step the layer of @p time is measured at: the one nearest to it.
inline std::int64_t layer_step(double time, double time_step) {
  return std::llround(time / time_step);
}

/// Layers of @p series measured by the end of step @p step, at time step @p time_step.
inline std::size_t layers_through(const LayerSeries& series, double time_step, std::int64_t step) {
  return static_cast<std::size_t>(
      std::count_if(series.times.begin(), series.times.end(),
                    [&](double t) { return layer_step(t, time_step) <= step; }));
}

/// The layers of `analysis.layers`, each measured at the step nearest its time:
/// layer_<n>.csv (solid fraction per bin, as layer.csv) and layers.csv (one summary row per layer,
/// rewritten whole after each, so that it can be read while the run goes on).
class LayerFiles : public Observer {
 public:
  /// @p series must outlive the observer.
  LayerFiles(std::filesystem::path directory, const LayerSeries& series, double time_step);

  /// Continue from the checkpoint at @p checkpoint_step: keep layers.csv's rows of the layers
  /// measured up to it, drop the later ones (the layer files of those are rewritten when their
  /// steps come). Throws std::runtime_error when layers.csv lacks the kept rows.
  void resume(std::int64_t checkpoint_step);
  void after_step(const Simulation& simulation) override;
  /// At the steps of layers not measured yet.
  bool reads_state(const Simulation& /*simulation*/, std::int64_t step) const override {
    return next_ < series_.times.size() && layer_step(series_.times[next_], time_step_) <= step;
  }

 private:
  void write_summary() const;

  std::filesystem::path directory_;
  const LayerSeries& series_;
  double time_step_;
  std::size_t next_ = 0;  ///< layers measured so far
  std::string header_;
  std::vector<std::string> rows_;
};

/// checkpoint.bin (particles, stepper state, the history's text, the case fingerprint) every
/// @p every steps, at a stop request and at the end; nothing on a blow-up.
class CheckpointFile : public Observer {
 public:
  CheckpointFile(std::string path, std::uint64_t fingerprint, std::int64_t every,
                 const History& history);
  void after_step(const Simulation& simulation) override;
  /// At its checkpoints' steps (the last one is finish()'s).
  bool reads_state(const Simulation& simulation, std::int64_t step) const override {
    return step % every_ == 0 && step != simulation.last_step();
  }
  void interrupted(const Simulation& simulation, const Interruption& why) override;
  /// Starts the end-of-run checkpoint on a thread of its own, so that the device's time (0.15 s
  /// for the 231 MB of 10^6 particles) passes while the analysis and the end-of-run files are
  /// made; those appear only after it (wait_written()). The scene and the stepper must outlive
  /// the writing and stay as they are until wait_written() returns.
  void finish(const Simulation& simulation) override;
  /// Waits until finish()'s checkpoint is in place; rethrows what writing it threw. Returns at
  /// once when none is being written.
  void wait_written();

 private:
  void write(const Scene& scene, const Stepper& stepper) const;

  std::string path_;
  std::uint64_t fingerprint_;
  std::int64_t every_;
  const History& history_;
  std::future<void> writing_;  ///< finish()'s checkpoint, while written
};

/// The end-of-run files in @p directory: final_state.csv, clusters.csv and, with a layer,
/// layer.csv, from @p analysis's figures (attach it after the analysis and @p checkpoint: none
/// of them appears before the checkpoint of its state, which it waits for). They appear together
/// or not at all. At a stop request, final_state.csv alone.
class EndOfRunFiles : public Observer {
 public:
  EndOfRunFiles(std::filesystem::path directory, const RunAnalysis& analysis,
                CheckpointFile& checkpoint);
  /// Never between steps: it writes at a stop request and at the end.
  bool reads_state(const Simulation& /*simulation*/, std::int64_t /*step*/) const override {
    return false;
  }
  void interrupted(const Simulation& simulation, const Interruption& why) override;
  void finish(const Simulation& simulation) override;

 private:
  std::filesystem::path directory_;
  const RunAnalysis& analysis_;
  CheckpointFile& checkpoint_;
};

}  // namespace bondem
