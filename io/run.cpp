#include "io/run.hpp"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <optional>
#include <ostream>
#include <regex>
#include <sstream>
#include <string_view>
#include <system_error>

#include "io/atomic_file.hpp"
#include "io/case_file.hpp"
#include "io/checkpoint.hpp"
#include "io/run_observers.hpp"
#include "io/run_plan.hpp"
#include "solver/driver/history.hpp"
#include "solver/driver/progress.hpp"
#include "solver/driver/run_analysis.hpp"
#include "solver/driver/simulation.hpp"
#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"
#include "solver/experiments/calculator.hpp"
#include "solver/setup/message_number.hpp"

namespace bondem {

std::string history_without_end_row(const std::string& history, std::int64_t step, double time,
                                    std::int64_t every) {
  if (step % every == 0 || history.size() < 2) return history;
  const std::size_t last_row = history.rfind('\n', history.size() - 2);
  if (last_row == std::string::npos) return history;  // the header only
  // Rows start with the time in 17 significant digits, which reads back as the same double.
  const double row_time = std::strtod(history.c_str() + last_row + 1, nullptr);
  return row_time == time ? history.substr(0, last_row + 1) : history;
}

namespace {

/// What in @p restored does not fit @p scene ("" when all fits): a checkpoint that passes its
/// checksum and fingerprint may still be forged, and the stepper indexes by these sizes.
/// @p particles: how many the checkpoint holds (more than restored.particles when only a part
/// of them was read); @p case_particles: how many the case places.
std::string checkpoint_misfit(const Checkpoint& restored, const Scene& scene, std::size_t materials,
                              std::size_t particles, std::size_t case_particles) {
  const Particles& p = restored.particles;
  const Particles& expected = scene.particles;  // its layout
  if (restored.stepper.streams.size() != scene.streams.size()) {
    return std::to_string(restored.stepper.streams.size()) + " particle streams, the case has " +
           std::to_string(scene.streams.size());
  }
  // The case's own particles, and what its streams inserted up to the checkpoint.
  std::size_t inserted = 0;
  for (const ParticleTally& stream : restored.stepper.streams) {
    if (stream.count < 0) return "a negative inserted count";
    inserted += static_cast<std::size_t>(stream.count);
  }
  const std::int64_t removed = restored.stepper.removed.count;
  if (removed < 0 || static_cast<std::size_t>(removed) > case_particles + inserted ||
      particles != case_particles + inserted - static_cast<std::size_t>(removed)) {
    return std::to_string(particles) + " particles, the case has " +
           std::to_string(case_particles) + ", its streams inserted " + std::to_string(inserted) +
           " and " + std::to_string(removed) + " were removed";
  }
  if (p.walls != expected.walls) {
    return std::to_string(p.walls) + " boundary contact slots, the case has " +
           std::to_string(expected.walls);
  }
  if (p.thermal() != expected.thermal()) {
    return p.thermal() ? "temperatures, the case is not thermal" : "no temperatures";
  }
  if (restored.stepper.boundaries.size() != kBoundaryStateValues * scene.boundaries.size()) {
    return "the state of " +
           std::to_string(restored.stepper.boundaries.size() / kBoundaryStateValues) +
           " boundaries, the case has " + std::to_string(scene.boundaries.size());
  }
  if (p.mesh_contacts != expected.mesh_contacts) {
    return p.mesh_contacts ? "mesh contact history, the case has no mesh" : "no mesh contacts";
  }
  for (const std::int32_t m : p.material) {
    if (m < 0 || static_cast<std::size_t>(m) >= materials) {
      return "material index " + std::to_string(m) + " of " + std::to_string(materials);
    }
  }
  return "";
}

/// @p argument as one shell word: unchanged when it holds only safe characters, else in single
/// quotes (a quote inside written as '\'').
std::string shell_quoted(const std::string& argument) {
  const bool safe = !argument.empty() && std::all_of(argument.begin(), argument.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) != 0 ||
           std::string_view("_-./=:,+@%").find(c) != std::string_view::npos;
  });
  if (safe) return argument;
  std::string quoted = "'";
  for (const char c : argument) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

}  // namespace

std::string resume_command(const RunOptions& options, const Case& description,
                           const std::filesystem::path& directory,
                           const std::string& checkpoint_path) {
  if (options.command_line.empty()) {
    // Called as a library: only what the run knows. A built-in case has no file to name.
    const std::string case_argument =
        description.source.rfind('<', 0) == 0 ? "" : shell_quoted(description.source) + " ";
    return "bondem run " + case_argument + "--output " + shell_quoted(directory.string()) +
           " --restart " + shell_quoted(checkpoint_path) +
           " (and the options of the interrupted run, if any)";
  }
  std::string command;
  const std::vector<std::string>& words = options.command_line;
  for (std::size_t k = 0; k < words.size(); ++k) {
    if (words[k] == "--restart") {
      ++k;  // and its value
      continue;
    }
    if (words[k].rfind("--restart=", 0) == 0) continue;
    if (!command.empty()) command += ' ';
    command += shell_quoted(words[k]);
  }
  return command + " --restart " + shell_quoted(checkpoint_path);
}

namespace {

/// Create @p directory and write and remove a probe file in it, so that an output directory that
/// cannot be written is refused before step 0 rather than found at the first write. @p key names
/// the setting that chose the directory. Throws CaseError.
void probe_output_directory(const std::filesystem::path& directory, const std::string& key) {
  const auto refuse = [&](const std::string& why) {
    throw CaseError(key + ": cannot write the output directory " + directory.string() + " (" + why +
                    ")");
  };
  std::error_code error;
  std::filesystem::create_directories(directory, error);
  if (error) refuse(error.message());
  if (!std::filesystem::is_directory(directory, error)) refuse("not a directory");
  const std::filesystem::path probe =
      directory / (".bondem_probe.tmp." + std::to_string(::getpid()));
  bool written = false;
  {
    std::ofstream out(probe, std::ios::binary | std::ios::trunc);
    out << "bondem\n";
    out.flush();
    written = static_cast<bool>(out);
  }
  std::filesystem::remove(probe, error);
  if (!written) refuse("a test file cannot be written");
  if (error) refuse("a test file cannot be removed: " + error.message());
}

/// True for a VTK series file: a collection `<kind>.pvd`, a frame `<kind>_NNNNNN.vtp` (six or
/// more digits) of the particles, contacts, walls or tools, or a distributed run's piece
/// `<kind>_NNNNNN_P.vtp` and summary `<kind>_NNNNNN.pvtp`.
bool is_vtk_series(const std::string& name) {
  static const std::regex frame(
      "(particles|contacts|bonds|walls|tools)(\\.pvd|_[0-9]{6,}(_[0-9]+)?\\.vtp|_[0-9]{6,}\\."
      "pvtp)");
  return name == "domain.vtp" || std::regex_match(name, frame);
}

/// True for the names of the files bondem's runs write (outputs, VTK series), and only those.
bool is_run_output(const std::string& name) {
  for (const char* output : {"history.csv", "final_state.csv", "last_good_state.csv",
                             "clusters.csv", "layer.csv", "layers.csv", "checkpoint.bin"}) {
    if (name == output) return true;
  }
  return is_vtk_series(name) || state_file_index(name) >= 0 || layer_file_number(name) >= 0;
}

/// Names of an earlier run's outputs moved aside (remove_stale_outputs): temporaries of this
/// process, `.bondem_stale_<n>.tmp.<pid>`.
constexpr std::string_view kStaleScratch = ".bondem_stale_";

/// A run owns its output directory: remove what an earlier run left in it, so that every file
/// there belongs to this run. Removed: temporaries `<output>.tmp.<pid>` of processes that no
/// longer run (a SIGKILL during a write), and every output bondem writes (is_run_output()),
/// except @p keep (the checkpoint a restart reads), when @p keep_vtk_series the VTK series (a
/// restart trims it to the checkpoint's time itself), and the state snapshots up to index
/// @p keep_states_through (-1: none), and with @p keep_layers_through >= 0 layers.csv and the
/// layer files up to that number (a restart trims layers.csv itself). Files bondem does not
/// write stay. An output is renamed to a temporary of this process at once, which nothing of
/// this run writes, and unlinked by the returned removal (StaleOutputRemoval), with the
/// temporaries of dead processes.
StaleOutputRemoval remove_stale_outputs(const std::filesystem::path& directory,
                                        const std::filesystem::path& keep, bool keep_vtk_series,
                                        std::int64_t keep_states_through,
                                        std::int64_t keep_layers_through) {
  namespace fs = std::filesystem;
  std::error_code error;
  std::vector<fs::path> stale;
  std::vector<fs::path> dead_temporaries;  // names no live process writes: unlinked as they are
  for (const fs::directory_entry& entry : fs::directory_iterator(directory, error)) {
    if (!entry.is_regular_file(error)) continue;
    const std::string name = entry.path().filename().string();
    const std::size_t marker = name.rfind(".tmp.");
    if (marker != std::string::npos) {
      const std::string pid = name.substr(marker + 5);
      const std::string target = name.substr(0, marker);
      const bool digits =
          !pid.empty() && pid.size() < 10 &&
          std::all_of(pid.begin(), pid.end(), [](char c) { return c >= '0' && c <= '9'; });
      if (!digits ||
          !(is_run_output(target) || target == ".bondem_probe" ||
            target.rfind(kLastGoodScratch, 0) == 0 || target.rfind(kStaleScratch, 0) == 0)) {
        continue;
      }
      const auto owner = static_cast<pid_t>(std::stol(pid));
      // A live process may be writing it (another run aimed at the same directory).
      const bool alive = owner == ::getpid() || ::kill(owner, 0) == 0 || errno != ESRCH;
      if (!alive) dead_temporaries.push_back(entry.path());
      continue;
    }
    if (!is_run_output(name)) continue;
    if (keep_vtk_series && is_vtk_series(name)) continue;
    if (const std::int64_t state = state_file_index(name);
        state >= 0 && state <= keep_states_through) {
      continue;
    }
    if (const std::int64_t layer = layer_file_number(name);
        keep_layers_through >= 0 &&
        (name == "layers.csv" || (layer >= 0 && layer <= keep_layers_through))) {
      continue;
    }
    std::error_code not_same;  // keep may not exist: then nothing is kept
    if (!keep.empty() && fs::equivalent(entry.path(), keep, not_same)) continue;
    stale.push_back(entry.path());
  }
  if (error) {
    throw std::runtime_error(directory.string() +
                             ": cannot list the output directory: " + error.message());
  }
  std::vector<fs::path> moved = std::move(dead_temporaries);
  std::vector<fs::path> offered;
  const std::string pid = std::to_string(::getpid());
  for (const fs::path& path : stale) {
    fs::path aside = directory / (std::string(kStaleScratch) +
                                  std::to_string(moved.size() + offered.size()) + ".tmp." + pid);
    // Whether this run writes it again through an AtomicFile (every run that ends writes these
    // two; state snapshots are left out: held until the end, many large ones would keep their
    // disk space through the run), large enough to be written direct, and linked by no other
    // name (a hard link made to keep it must keep its bytes).
    const std::string name = path.filename().string();
    std::error_code unknown;  // a file that cannot be asked is unlinked, as before
    const bool rewritten = (name == "checkpoint.bin" || name == "final_state.csv") &&
                           fs::hard_link_count(path, unknown) == 1 && !unknown &&
                           fs::file_size(path, unknown) >= FileWriteBuffer::kBufferBytes &&
                           !unknown;
    fs::rename(path, aside, error);
    if (error) {
      throw std::runtime_error(path.string() +
                               ": cannot remove an earlier run's output: " + error.message());
    }
    if (rewritten) {
      offer_for_rewrite(path, aside);
      offered.push_back(std::move(aside));
    } else {
      moved.push_back(std::move(aside));
    }
  }
  return StaleOutputRemoval(std::move(moved), std::move(offered));
}

}  // namespace

RunPlan plan_run(const Case& description, const RunOptions& options) {
  RunPlan plan;
  plan.limit = case_time_step_bound(description);
  const double recommended = plan.limit.step;
  if (options.enforce_time_step_limit && description.time_step > recommended) {
    std::ostringstream message;
    message << description.source << ": 'time.step': " << description.time_step
            << " s is above the limit " << recommended << " s set by " << plan.limit.cause
            << " (see bondem info); lower time.step (or --unsafe-time-step)";
    throw CaseError(message.str());
  }
  plan.directory =
      options.output_directory.empty() ? description.output_directory : options.output_directory;
  plan.checkpoint_path = (plan.directory / "checkpoint.bin").string();
  plan.fingerprint = case_fingerprint(description);
  plan.restarting = !options.restart_path.empty();

  // In double first: the ratio of a long end and a tiny step does not fit any integer.
  const double step_ratio = description.end_time / description.time_step;
  if (!(step_ratio <= kMaxSteps)) {
    throw CaseError(description.source + ": 'time.end': " + message_number(description.end_time) +
                    " s is " + message_number(step_ratio) + " steps of time.step " +
                    message_number(description.time_step) + " s, more than the limit of " +
                    message_number(kMaxSteps) + " steps");
  }
  plan.steps = static_cast<std::int64_t>(std::llround(step_ratio));
  // An interval at least as long as the run means "at the end only" (the end is always written);
  // the ratio stays in double until it is known to fit.
  const auto every = [&](double interval, double fallback) {
    const double ratio = (interval > 0.0 ? interval : fallback) / description.time_step;
    if (!(ratio < step_ratio)) return std::numeric_limits<std::int64_t>::max();
    return std::max<std::int64_t>(1, std::llround(ratio));
  };
  plan.history_every = every(description.history_interval, description.end_time / 100.0);
  plan.vtk_every = every(description.vtk_interval, 2.0 * description.end_time);
  plan.checkpoint_every = every(description.checkpoint_interval, 2.0 * description.end_time);
  if (description.state_interval > 0.0) {
    plan.state_every = every(description.state_interval, description.state_interval);
  }
  return plan;
}

void check_checkpoint_fingerprint(std::uint64_t fingerprint, const Case& description,
                                  const RunOptions& options, const RunPlan& plan) {
  if (fingerprint != plan.fingerprint) {
    throw CaseError(options.restart_path +
                    ": checkpoint was written by a different case (its "
                    "materials, laws, time step, domain, walls or particle count differ from " +
                    description.source + ")");
  }
}

Checkpoint read_fitting_checkpoint(const Case& description, const RunOptions& options,
                                   const RunPlan& plan, const Scene& scene,
                                   std::size_t case_particles,
                                   const std::vector<std::uint64_t>* rows) {
  Checkpoint restored;
  try {
    // The pairs are read as the stepper takes them, into its slots: never all in memory.
    restored = read_checkpoint(options.restart_path,
                               CheckpointScope{.rows = rows, .pairs_streamed = true});
  } catch (const CheckpointError& e) {
    throw CaseError(e.what());
  }
  check_checkpoint_fingerprint(restored.case_fingerprint, description, options, plan);
  if (const std::string misfit = checkpoint_misfit(restored, scene, description.materials.size(),
                                                   restored.file_particles, case_particles);
      !misfit.empty()) {
    throw CaseError(options.restart_path + ": checkpoint does not fit the case: it holds " +
                    misfit);
  }
  if (plan.steps <= restored.stepper.step) {
    throw CaseError(description.source + ": 'time.end': " + message_number(description.end_time) +
                    " s is not after the time of the checkpoint " + options.restart_path + ", " +
                    message_number(restored.stepper.time) +
                    " s: raise time.end to continue the run");
  }
  return restored;
}

StaleOutputRemoval::StaleOutputRemoval(std::vector<std::filesystem::path> moved,
                                       std::vector<std::filesystem::path> offered)
    : offered_(std::move(offered)) {
  if (moved.empty()) return;
  // A file left (an error) is a temporary of this process: the next run removes it.
  const auto unlink_all = [](const std::vector<std::filesystem::path>& paths) {
    std::error_code ignored;
    for (const std::filesystem::path& path : paths) std::filesystem::remove(path, ignored);
  };
  try {
    unlinking_ = std::thread([moved, unlink_all] { unlink_all(moved); });
  } catch (const std::system_error&) {
    unlink_all(moved);  // no thread to be had: here, as before
  }
}

void StaleOutputRemoval::wait() noexcept {
  if (unlinking_.joinable()) unlinking_.join();
  if (offered_.empty()) return;
  std::error_code ignored;
  try {
    for (const std::filesystem::path& path : withdraw_rewrites(offered_)) {
      std::filesystem::remove(path, ignored);
    }
  } catch (const std::exception&) {  // no memory for the list: the next run removes them
  }
  offered_.clear();
}

StaleOutputRemoval prepare_output_directory(const Case& description, const RunOptions& options,
                                            const RunPlan& plan) {
  probe_output_directory(plan.directory, options.output_directory.empty()
                                             ? description.source + ": 'output.directory'"
                                             : "--output " + options.output_directory);
  const bool keep_vtk_series = plan.restarting && description.vtk_interval > 0.0;
  // A restart keeps the snapshots an uninterrupted run writes up to its checkpoint.
  const std::int64_t keep_states =
      plan.restarting && plan.state_every > 0 ? plan.first_step / plan.state_every : -1;
  // And the layers measured up to it (LayerFiles::resume trims layers.csv to them).
  const std::int64_t keep_layers =
      plan.restarting && description.layers
          ? static_cast<std::int64_t>(
                layers_through(*description.layers, description.time_step, plan.first_step))
          : -1;
  return remove_stale_outputs(plan.directory, plan.restarting ? options.restart_path : "",
                              keep_vtk_series, keep_states, keep_layers);
}

std::string blow_up_message(const BlowUpError& e, const Case& description, const RunPlan& plan) {
  const double recommended = plan.limit.step;
  std::ostringstream message;
  message << e.what() << ". Likely cause: ";
  // Blame the time step only when it is above its limit (--unsafe-time-step).
  if (description.time_step > recommended) {
    message << "time.step = " << description.time_step << " s above its limit " << recommended
            << " s set by " << plan.limit.cause << "; try a smaller step";
  } else if (e.cause() == BlowUpCause::kHeat) {
    message << "heat flows too fast for the explicit heat step, or an absurd temperature or "
               "laser power; lower time.step or check the thermal properties and the laser";
  } else if (e.cause() == BlowUpCause::kTool) {
    message << "the tool named above drives particles into each other or a wall faster than "
               "the contacts push back (time.step is within its limit); slow it or check its path";
  } else if (e.cause() == BlowUpCause::kHistory) {
    message << "a total too large for a double: check the initial velocities, temperatures and "
               "material properties for absurd values";
  } else {
    message << "initial overlaps, a stiff material or a wall cutting particles (time.step is "
               "within its limit "
            << recommended << " s)";
  }
  message << ". Last good state: " << (plan.directory / "last_good_state.csv").string();
  return message.str();
}

void check_output_fields(const Case& description, const Scene& scene,
                         const std::string& restored_history) {
  const RunTotals totals;
  std::vector<HistoryColumn> columns;
  try {
    columns = select_history_columns(history_columns(scene, totals), description.history_fields);
  } catch (const std::invalid_argument& e) {
    throw CaseError(description.history_fields_origin + ": " + e.what());
  }
  if (!description.vtk_fields.empty()) {
    const std::vector<std::string> arrays =
        VtkSeriesWriter::particle_array_names(scene.particles, VtkFrames::derived_arrays());
    for (const std::string& name : description.vtk_fields) {
      if (std::find(arrays.begin(), arrays.end(), name) != arrays.end()) continue;
      std::string available;
      for (const std::string& a : arrays) available += (available.empty() ? "" : ", ") + a;
      throw CaseError(description.vtk_fields_origin + ": no particle array '" + name +
                      "' in this run (it has " + available + ")");
    }
  }
  if (restored_history.empty()) return;
  const std::string header = history_header(columns);
  if (restored_history.compare(0, header.size(), header) != 0) {
    throw CaseError(description.source +
                    ": 'output.history_fields': the history the checkpoint continues has other "
                    "columns (" +
                    restored_history.substr(0, restored_history.find('\n')) +
                    "); a restart keeps them");
  }
}

RunResult collect_result(const RunEnd& end, const RunCounts& counts, const RunFigures& figures) {
  const std::size_t n = counts.particles;
  RunResult result;
  result.steps = end.step - end.first_step;
  result.particles = n;
  result.threads = threads_in_use(n);
  result.wall_seconds = end.loop_seconds;
  result.particle_steps_per_second =
      end.loop_seconds > 0.0
          ? static_cast<double>(result.steps) * static_cast<double>(n) / end.loop_seconds
          : 0.0;
  result.neighbor_builds = counts.neighbor_builds;
  result.contacts = counts.contacts;
  result.packing = figures.packing;
  result.packing_region = figures.packing_region;
  result.layer = figures.layer;
  result.clusters = figures.agglomerates;
  result.largest_cluster = figures.largest_cluster;
  result.unbonded = figures.unbonded;
  result.primary_sizes = figures.primary_sizes;
  result.cluster_sizes = figures.cluster_sizes;
  result.bonds_formed = counts.bonds_formed;
  result.bonds_broken = counts.bonds_broken;
  result.thermal = figures.thermal;
  return result;
}

RunResult collect_result(const RunEnd& end, const Simulation& simulation,
                         const RunFigures& figures) {
  const Stepper& stepper = simulation.stepper();
  RunCounts counts;
  counts.particles = simulation.scene().particles.size();
  counts.neighbor_builds = stepper.neighbors().build_count();
  counts.contacts = stepper.contacts();
  counts.bonds_formed = stepper.bonds_formed();
  counts.bonds_broken = stepper.bonds_broken();
  return collect_result(end, counts, figures);
}

namespace {

/// Step @p stepper to the plan's end with the run's observers, in the order their files must
/// appear: progress, history (continuing @p history_text on a restart), last good state, VTK,
/// checkpoint, analysis, end-of-run files. Throws BlowUpError or RunInterrupted when the run ends
/// early, with the message to show.
RunResult simulate(const Case& description, const RunOptions& options, const RunPlan& plan,
                   const Scene& scene, Stepper& stepper, std::string history_text,
                   std::ostream& log) {
  std::optional<VtkFrames> vtk;  // first: a restart trims the series before the history is opened
  if (description.vtk_interval > 0.0) {
    vtk.emplace(plan.directory, plan.vtk_every, description.vtk_fields);
    if (plan.restarting) vtk->resume(scene, stepper.step_count(), description.time_step);
  }
  // A restart first rewrites history.csv from the checkpoint. After a blow-up or an interruption
  // it holds every row the run produced; a checkpoint.bin beside it may be older (its own history
  // is inside it).
  HistoryFile history_file((plan.directory / "history.csv").string());
  History history(
      scene, plan.history_every,
      [&history_file](const std::string& text) { history_file.append(text); },
      description.history_fields);
  if (plan.restarting) history.continue_from(std::move(history_text));
  Progress progress(log, options.quiet);
  LastGoodFile last_good((plan.directory / "last_good_state.csv").string(), scene.particles,
                         history);
  CheckpointFile checkpoint(plan.checkpoint_path, plan.fingerprint, plan.checkpoint_every, history);
  RunAnalysis analysis(description);
  EndOfRunFiles end_files(plan.directory, analysis, checkpoint);
  std::optional<StateFiles> states;
  if (plan.state_every > 0) states.emplace(plan.directory, plan.state_every);
  std::optional<LayerFiles> layers;
  if (description.layers) {
    layers.emplace(plan.directory, *description.layers, description.time_step);
    if (plan.restarting) layers->resume(stepper.step_count());
  }

  Simulation simulation(scene, stepper, plan.steps);
  simulation.stop_when(options.stop_requested);
  for (Observer* observer : std::initializer_list<Observer*>{
           &progress, &history, &last_good, vtk ? &*vtk : nullptr, states ? &*states : nullptr,
           layers ? &*layers : nullptr, &checkpoint, &analysis, &end_files}) {
    if (observer != nullptr) simulation.attach(*observer);
  }
  const RunEnd end = simulation.run();
  checkpoint.wait_written();  // EndOfRunFiles has waited for it, unless the run ended otherwise
  if (end.blow_up) {
    throw BlowUpError(blow_up_message(*end.blow_up, description, plan), end.blow_up->cause());
  }
  if (!end.finished) {
    std::ostringstream message;
    message << "interrupted at step " << end.step << " (t = " << stepper.time()
            << " s); checkpoint written. Resume with: "
            << resume_command(options, description, plan.directory, plan.checkpoint_path);
    throw RunInterrupted(message.str());
  }
  return collect_result(end, simulation, *analysis.figures());
}

}  // namespace

RunResult run_case(Case description, const RunOptions& options, std::ostream& log) {
  RunPlan plan = plan_run(description, options);
  Scene scene = build_scene(description);
  // The case's particle list has become the scene's particles, its initial pairs the scene's,
  // and the plan holds what was derived from them (fingerprint, limits): the run does not keep a
  // second copy (104 B a particle, 72 B a pair).
  description.particles.clear();
  std::vector<SlipRecord>().swap(description.initial_pairs);
  std::optional<Stepper> stepper;
  std::string history_text;  // of the checkpoint a restart continues
  // Only VTK frames read each pair's force (their contacts).
  scene.pair_forces_read = description.vtk_interval > 0.0;
  if (plan.restarting) {
    Checkpoint restored =
        read_fitting_checkpoint(description, options, plan, scene, scene.particles.size());
    plan.first_step = restored.stepper.step;
    scene.particles = std::move(restored.particles);
    // A restart that writes VTK frames the interrupted run did not track displacements from
    // here, from zero.
    if (description.vtk_interval > 0.0 && !scene.particles.displacement_tracked) {
      scene.particles.track_displacement();
    }
    history_text = history_without_end_row(restored.history, restored.stepper.step,
                                           restored.stepper.time, plan.history_every);
    stepper.emplace(scene, std::move(restored.stepper));
  } else {
    stepper.emplace(scene);
  }
  check_output_fields(description, scene, history_text);
  const StaleOutputRemoval stale = prepare_output_directory(description, options, plan);
  return simulate(description, options, plan, scene, *stepper, std::move(history_text), log);
}

}  // namespace bondem
