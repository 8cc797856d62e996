#include "io/run.hpp"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <numeric>
#include <optional>
#include <ostream>
#include <sstream>
#include <string_view>

#include "io/atomic_file.hpp"
#include "io/case_file.hpp"
#include "io/checkpoint.hpp"
#include "io/vtk_output.hpp"
#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"
#include "solver/experiments/calculator.hpp"
#include "solver/setup/message_number.hpp"

namespace bondem {
namespace {

/// Shortest exact text of a double: the same bits always give the same bytes.
std::string exact(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.17g", value);
  return buffer;
}

/// @p history (a checkpoint's history.csv text) without its last row when that row is the end
/// row of a finished run, at the checkpoint's @p step and @p time but off the grid of one row
/// every @p every steps: a run straight to a later end has no row there.
std::string history_without_end_row(const std::string& history, std::int64_t step, double time,
                                    std::int64_t every) {
  if (step % every == 0 || history.size() < 2) return history;
  const std::size_t last_row = history.rfind('\n', history.size() - 2);
  if (last_row == std::string::npos) return history;  // the header only
  // Rows start with the time in 17 significant digits, which reads back as the same double.
  const double row_time = std::strtod(history.c_str() + last_row + 1, nullptr);
  return row_time == time ? history.substr(0, last_row + 1) : history;
}

/// One column of history.csv: its name, its unit, and how to read it from the run.
struct HistoryColumn {
  std::string name;
  const char* unit;  ///< "" for counts
  std::function<double()> value;
};

/// The columns of history.csv, declared once: the header and every row come from this list. Counts
/// are exact in a double (below 2^53) and print as integers. @p loads must hold the wall and tool
/// loads of the row being written (Stepper::wall_forces(), read once per row).
std::vector<HistoryColumn> history_columns(const Scene& scene, const Stepper& stepper,
                                           const std::vector<Eigen::Vector3d>& loads) {
  const auto count = [](auto n) { return static_cast<double>(n); };
  std::vector<HistoryColumn> columns{
      {"time", "s", [&] { return stepper.time(); }},
      {"kinetic_energy", "J", [&] { return stepper.kinetic_energy(); }},
      {"rotational_energy", "J", [&] { return stepper.rotational_energy(); }},
      {"contacts", "", [&, count] { return count(stepper.contacts().contacts); }},
      {"bonds", "", [&, count] { return count(stepper.contacts().bonds); }},
      {"bonds_formed", "", [&, count] { return count(stepper.bonds_formed()); }},
      {"bonds_broken", "", [&, count] { return count(stepper.bonds_broken()); }},
      {"wall_contacts", "", [&, count] { return count(stepper.contacts().wall_contacts); }},
      {"max_overlap", "m", [&] { return stepper.contacts().max_overlap; }}};
  if (scene.particles.thermal()) {
    const std::vector<double>& t = scene.particles.temperature;
    columns.push_back(
        {"max_temperature", "K", [&t] { return *std::max_element(t.begin(), t.end()); }});
    columns.push_back({"mean_temperature", "K", [&t] {
                         double sum = 0.0;
                         for (const double value : t) sum += value;  // index order: any threads
                         return sum / static_cast<double>(t.size());
                       }});
    columns.push_back({"laser_energy", "J", [&] { return stepper.laser_energy(); }});
  }
  // The force the particles exert on each wall, then each tool.
  std::vector<std::string> names;
  for (const PlaneWall& wall : scene.walls) names.push_back(wall.name);
  for (const Body& body : scene.bodies) names.push_back(body.name);
  for (std::size_t k = 0; k < names.size(); ++k) {
    for (const int axis : {0, 1, 2}) {
      columns.push_back({"load_" + names[k] + "_" + "xyz"[axis], "N",
                         [&loads, k, axis] { return loads[k][axis]; }});
    }
  }
  return columns;
}

/// The header line of history.csv.
std::string history_header(const std::vector<HistoryColumn>& columns) {
  std::string header;
  for (const HistoryColumn& column : columns) header += (header.empty() ? "" : ",") + column.name;
  return header + '\n';
}

/// Bonds per particle in the last force evaluation.
std::vector<int> bond_counts(const Particles& p, const Stepper& stepper) {
  std::vector<int> counts(p.size(), 0);
  const NeighborList& list = stepper.neighbors();
  list.for_each_pair([&](std::size_t i, std::size_t j, std::uint32_t k) {
    if (stepper.pair_forces().bonded[k] == 0) return;
    ++counts[i];
    ++counts[j];
  });
  return counts;
}

/// One row per particle sorted by id; thermal runs add temperatures and each particle's bonds.
void write_final_state(const Particles& p, const std::string& path,
                       const std::vector<int>& bonds = {}) {
  std::vector<std::size_t> order(p.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return p.id[a] < p.id[b]; });
  AtomicFile file(path);
  std::ostream& out = file.stream();
  const bool thermal = p.thermal() && bonds.size() == p.size();
  out << "id,x,y,z,vx,vy,vz,radius" << (thermal ? ",temperature,peak_temperature,bonds" : "")
      << '\n';
  for (const std::size_t i : order) {
    out << p.id[i] << ',' << exact(p.x[i]) << ',' << exact(p.y[i]) << ',' << exact(p.z[i]) << ','
        << exact(p.vx[i]) << ',' << exact(p.vy[i]) << ',' << exact(p.vz[i]) << ','
        << exact(p.radius[i]);
    if (thermal) {
      out << ',' << exact(p.temperature[i]) << ',' << exact(p.peak_temperature[i]) << ','
          << bonds[i];
    }
    out << '\n';
  }
  file.commit();
}

/// What in @p restored does not fit @p scene ("" when all fits): a checkpoint that passes its
/// checksum and fingerprint may still be forged, and the stepper indexes by these sizes.
std::string checkpoint_misfit(const Checkpoint& restored, const Scene& scene,
                              std::size_t materials) {
  const Particles& p = restored.particles;
  const Particles& expected = scene.particles;
  if (p.size() != expected.size()) {
    return std::to_string(p.size()) + " particles, the case has " + std::to_string(expected.size());
  }
  if (p.walls != expected.walls) {
    return std::to_string(p.walls) + " walls and tools, the case has " +
           std::to_string(expected.walls);
  }
  if (p.thermal() != expected.thermal()) {
    return p.thermal() ? "temperatures, the case is not thermal" : "no temperatures";
  }
  if (restored.stepper.bodies.size() != 6 * scene.bodies.size()) {
    return "the state of " + std::to_string(restored.stepper.bodies.size() / 6) +
           " tools, the case has " + std::to_string(scene.bodies.size());
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

/// The command that continues an interrupted run: the one that started it, with its --restart
/// (if any) replaced by @p checkpoint_path.
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

/// True for a VTK series file: a collection `<kind>.pvd` or a frame `<kind>_NNNNNN.vtp` (six or
/// more digits) of the particles, contacts, walls or tools.
bool is_vtk_series(const std::string& name) {
  for (const std::string kind : {"particles", "contacts", "walls", "tools"}) {
    if (name == kind + ".pvd") return true;
    const std::size_t first_digit = kind.size() + 1;
    if (name.size() < first_digit + 6 + 4 || name.compare(0, first_digit, kind + "_") != 0 ||
        name.compare(name.size() - 4, 4, ".vtp") != 0) {
      continue;
    }
    const auto digits_end = name.end() - 4;
    if (std::all_of(name.begin() + static_cast<std::ptrdiff_t>(first_digit), digits_end,
                    [](char c) { return c >= '0' && c <= '9'; })) {
      return true;
    }
  }
  return false;
}

/// True for the names of the files bondem's runs write (outputs, VTK series), and only those.
bool is_run_output(const std::string& name) {
  for (const char* output : {"history.csv", "final_state.csv", "last_good_state.csv",
                             "clusters.csv", "layer.csv", "checkpoint.bin"}) {
    if (name == output) return true;
  }
  return is_vtk_series(name);
}

/// A run owns its output directory: remove what an earlier run left in it, so that every file
/// there belongs to this run. Removed: temporaries `<output>.tmp.<pid>` of processes that no
/// longer run (a SIGKILL during a write), and every output bondem writes (is_run_output()),
/// except @p keep (the checkpoint a restart reads) and, when @p keep_vtk_series, the VTK series
/// (a restart trims it to the checkpoint's time itself). Files bondem does not write stay.
void remove_stale_outputs(const std::filesystem::path& directory, const std::filesystem::path& keep,
                          bool keep_vtk_series) {
  namespace fs = std::filesystem;
  std::error_code error;
  std::vector<fs::path> stale;
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
      if (!digits || !(is_run_output(target) || target == ".bondem_probe")) continue;
      const auto owner = static_cast<pid_t>(std::stol(pid));
      // A live process may be writing it (another run aimed at the same directory).
      const bool alive = owner == ::getpid() || ::kill(owner, 0) == 0 || errno != ESRCH;
      if (!alive) stale.push_back(entry.path());
      continue;
    }
    if (!is_run_output(name)) continue;
    if (keep_vtk_series && is_vtk_series(name)) continue;
    std::error_code not_same;  // keep may not exist: then nothing is kept
    if (!keep.empty() && fs::equivalent(entry.path(), keep, not_same)) continue;
    stale.push_back(entry.path());
  }
  if (error) {
    throw std::runtime_error(directory.string() +
                             ": cannot list the output directory: " + error.message());
  }
  for (const fs::path& path : stale) {
    if (!fs::remove(path, error) && error) {
      throw std::runtime_error(path.string() +
                               ": cannot remove an earlier run's output: " + error.message());
    }
  }
}

/// The files a run writes at its end: they appear together or not at all. Removes the ones
/// listed unless kept (an exception between the first write and keep() leaves none behind).
class OutputSet {
 public:
  explicit OutputSet(std::vector<std::filesystem::path> paths) : paths_(std::move(paths)) {}
  ~OutputSet() {
    if (kept_) return;
    std::error_code ignored;
    for (const std::filesystem::path& path : paths_) std::filesystem::remove(path, ignored);
  }
  OutputSet(const OutputSet&) = delete;
  OutputSet& operator=(const OutputSet&) = delete;
  void keep() { kept_ = true; }

 private:
  std::vector<std::filesystem::path> paths_;
  bool kept_ = false;
};

}  // namespace

namespace {

/// Progress on a terminal: one line rewritten in place; otherwise a plain line now and then.
class Progress {
 public:
  Progress(std::ostream& log, bool quiet, std::int64_t first_step, std::int64_t last_step,
           std::size_t particles)
      : log_(log),
        quiet_(quiet),
        terminal_(::isatty(::fileno(stderr)) != 0),
        first_(first_step),
        last_(last_step),
        particles_(static_cast<double>(particles)),
        start_(Clock::now()),
        shown_(start_) {}

  void update(std::int64_t step, double time) {
    if (quiet_ || (step & 31) != 0) return;
    const auto now = Clock::now();
    if (now - shown_ < (terminal_ ? std::chrono::milliseconds(500) : std::chrono::seconds(10)))
      return;
    shown_ = now;
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    const double rate = static_cast<double>(step - first_) / elapsed;
    std::ostringstream line;
    line.precision(4);
    line << "t = " << time << " s  "
         << 100.0 * static_cast<double>(step) / static_cast<double>(last_) << " %  " << rate
         << " steps/s  " << rate * particles_ << " particle-steps/s  "
         << static_cast<double>(last_ - step) / rate << " s left";
    if (terminal_) {
      log_ << '\r' << line.str() << "\x1b[K" << std::flush;
    } else {
      log_ << line.str() << '\n';
    }
  }

  void finish() {
    if (!quiet_ && terminal_) log_ << '\n';
  }

 private:
  using Clock = std::chrono::steady_clock;
  std::ostream& log_;
  bool quiet_;
  bool terminal_;
  std::int64_t first_, last_;
  double particles_;
  Clock::time_point start_, shown_;
};

/// Writes VTK frames of a run: particles (with coordination and bond count) and contacts.
class VtkObserver {
 public:
  explicit VtkObserver(const std::filesystem::path& directory) : writer_(directory.string()) {}

  /// Continue the series of an interrupted run from the checkpoint at @p checkpoint_step: keep
  /// the frames an uninterrupted run writes (every @p every steps) up to it, drop the rest (the
  /// frame written at an interruption, frames past the checkpoint).
  void resume(const Scene& scene, std::int64_t checkpoint_step, std::int64_t every,
              double time_step) {
    writer_.resume(
        [&](double time) {
          const std::int64_t step = std::llround(time / time_step);
          return step <= checkpoint_step && step % every == 0;
        },
        scene.walls, scene.domain);
  }

  void write(const Scene& scene, const Stepper& stepper) {
    const Particles& p = scene.particles;
    const NeighborList& list = stepper.neighbors();
    const PairForces& forces = stepper.pair_forces();
    coordination_.assign(p.size(), 0.0);
    bond_count_.assign(p.size(), 0.0);
    contacts_.clear();
    list.for_each_pair([&](std::size_t i, std::size_t j, std::uint32_t k) {
      // The end points are written to the file: the image of j is formed as a point first.
      const Eigen::Vector3d first(p.x[i], p.y[i], p.z[i]);
      const Eigen::Vector3d second = Eigen::Vector3d(p.x[j], p.y[j], p.z[j]) + list.shift(k);
      const Eigen::Vector3d d = second - first;
      const double overlap = p.radius[i] + p.radius[j] - d.norm();
      if (overlap <= 0.0) return;
      const Eigen::Vector3d force(forces.fx[k], forces.fy[k], forces.fz[k]);
      const bool bonded = forces.bonded[k] != 0;
      contacts_.push_back(
          {p.id[i], p.id[j], first, second, overlap, force.dot(d.normalized()), bonded});
      coordination_[i] += 1.0;
      coordination_[j] += 1.0;
      bond_count_[i] += bonded ? 1.0 : 0.0;
      bond_count_[j] += bonded ? 1.0 : 0.0;
    });
    std::vector<VtkSeriesWriter::ScalarField> scalars{{"coordination", &coordination_},
                                                      {"bond_count", &bond_count_}};
    if (p.thermal()) {
      scalars.push_back({"temperature", &p.temperature});
      scalars.push_back({"peak_temperature", &p.peak_temperature});
      scalars.push_back({"heat_rate", &p.heat_rate});
    }
    writer_.write_frame(
        stepper.time(), p, contacts_, scene.walls, scene.domain, scalars,
        {{"angular_velocity", &p.wx, &p.wy, &p.wz}, {"torque", &p.tx, &p.ty, &p.tz}}, scene.bodies);
  }

 private:
  VtkSeriesWriter writer_;
  std::vector<double> coordination_, bond_count_;
  std::vector<ContactRecord> contacts_;
};

}  // namespace

RunResult run_case(const Case& description, const RunOptions& options, std::ostream& log) {
  const TimeStepLimit limit = case_time_step_bound(description);
  const double recommended = limit.step;
  if (options.enforce_time_step_limit && description.time_step > recommended) {
    std::ostringstream message;
    message << description.source << ": 'time.step': " << description.time_step
            << " s is above the limit " << recommended << " s set by " << limit.cause
            << " (see bondem info); lower time.step (or --unsafe-time-step)";
    throw CaseError(message.str());
  }
  const std::filesystem::path directory =
      options.output_directory.empty() ? description.output_directory : options.output_directory;
  const std::string checkpoint_path = (directory / "checkpoint.bin").string();
  const std::uint64_t fingerprint = case_fingerprint(description);
  const bool restarting = !options.restart_path.empty();

  // In double first: the ratio of a long end and a tiny step does not fit any integer.
  const double step_ratio = description.end_time / description.time_step;
  if (!(step_ratio <= kMaxSteps)) {
    throw CaseError(description.source + ": 'time.end': " + message_number(description.end_time) +
                    " s is " + message_number(step_ratio) + " steps of time.step " +
                    message_number(description.time_step) + " s, more than the limit of " +
                    message_number(kMaxSteps) + " steps");
  }
  const auto steps = static_cast<std::int64_t>(std::llround(step_ratio));
  // An interval at least as long as the run means "at the end only" (the end is always written);
  // the ratio stays in double until it is known to fit.
  const auto every = [&](double interval, double fallback) {
    const double ratio = (interval > 0.0 ? interval : fallback) / description.time_step;
    if (!(ratio < step_ratio)) return std::numeric_limits<std::int64_t>::max();
    return std::max<std::int64_t>(1, std::llround(ratio));
  };

  Scene scene = build_scene(description);
  std::ostringstream history;
  std::optional<Stepper> stepper_storage;
  if (!restarting) {
    stepper_storage.emplace(scene);
  } else {
    Checkpoint restored;
    try {
      restored = read_checkpoint(options.restart_path);
    } catch (const CheckpointError& e) {
      throw CaseError(e.what());
    }
    if (restored.case_fingerprint != fingerprint) {
      throw CaseError(options.restart_path +
                      ": checkpoint was written by a different case (its "
                      "materials, laws, time step, domain, walls or particle count differ from " +
                      description.source + ")");
    }
    if (const std::string misfit = checkpoint_misfit(restored, scene, description.materials.size());
        !misfit.empty()) {
      throw CaseError(options.restart_path + ": checkpoint does not fit the case: it holds " +
                      misfit);
    }
    if (steps <= restored.stepper.step) {
      throw CaseError(description.source + ": 'time.end': " + message_number(description.end_time) +
                      " s is not after the time of the checkpoint " + options.restart_path + ", " +
                      message_number(restored.stepper.time) +
                      " s: raise time.end to continue the run");
    }
    scene.particles = std::move(restored.particles);
    stepper_storage.emplace(scene, restored.stepper);
    history << history_without_end_row(
        restored.history, restored.stepper.step, restored.stepper.time,
        every(description.history_interval, description.end_time / 100.0));
  }
  Stepper& stepper = *stepper_storage;
  std::vector<Eigen::Vector3d> loads;  // of the row being written
  const std::vector<HistoryColumn> columns = history_columns(scene, stepper, loads);
  if (!restarting) history << history_header(columns);

  const std::int64_t history_every =
      every(description.history_interval, description.end_time / 100.0);
  const std::int64_t vtk_every = every(description.vtk_interval, 2.0 * description.end_time);
  const std::int64_t checkpoint_every =
      every(description.checkpoint_interval, 2.0 * description.end_time);

  // Everything is checked: make the output directory this run's (see remove_stale_outputs).
  probe_output_directory(directory, options.output_directory.empty()
                                        ? description.source + ": 'output.directory'"
                                        : "--output " + options.output_directory);
  const bool vtk_series = description.vtk_interval > 0.0;
  remove_stale_outputs(directory, restarting ? options.restart_path : "", restarting && vtk_series);
  std::optional<VtkObserver> vtk;
  if (vtk_series) {
    vtk.emplace(directory);
    if (restarting) vtk->resume(scene, stepper.step_count(), vtk_every, description.time_step);
  }
  // history.csv grows row by row, flushed, so that a run can be watched (and plotted) live; a
  // restart first rewrites it from the checkpoint. After a blow-up or an interruption it holds
  // every row the run produced; a checkpoint.bin beside it may be older (its own history is
  // inside it).
  const std::string history_path = (directory / "history.csv").string();
  std::ofstream live_history(history_path, std::ios::binary | std::ios::trunc);
  const auto append_history = [&](const std::string& rows) {
    live_history << rows << std::flush;
    if (!live_history) throw std::runtime_error(history_path + ": write failed");
  };
  append_history(history.str());

  // One row of history.csv, appended and flushed. A value that is not finite (an infinite
  // kinetic energy while every position is still finite) is a blow-up like any other: the row
  // is not written and BlowUpError names the column and the fastest particle.
  const auto record = [&] {
    loads = stepper.wall_forces();
    std::ostringstream row;
    std::string non_finite;  // the first column that is not finite
    for (const HistoryColumn& column : columns) {
      const double value = column.value();
      row << (&column == &columns.front() ? "" : ",") << exact(value);
      if (non_finite.empty() && !std::isfinite(value)) {
        non_finite = column.name + " = " + exact(value) + (*column.unit ? " " : "") + column.unit;
      }
    }
    row << '\n';
    if (!non_finite.empty()) {
      std::ostringstream message;
      message << "step " << stepper.step_count() << " (t = " << stepper.time()
              << " s): history value " << non_finite;
      const Particles& p = scene.particles;
      std::size_t fastest = 0;
      double fastest_speed_sq = -1.0;
      for (std::size_t i = 0; i < p.size(); ++i) {
        const double speed_sq = p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i] + p.vz[i] * p.vz[i];
        if (speed_sq > fastest_speed_sq ||
            (std::isnan(speed_sq) && !std::isnan(fastest_speed_sq))) {
          fastest = i;
          fastest_speed_sq = speed_sq;
        }
      }
      if (p.size() > 0) {
        message << "; fastest particle id " << p.id[fastest] << " at "
                << std::sqrt(fastest_speed_sq) << " m/s";
      }
      throw BlowUpError(message.str(), BlowUpCause::kHistory);
    }
    history << row.str();
    append_history(row.str());
  };
  const auto checkpoint = [&] {
    write_checkpoint(checkpoint_path,
                     {fingerprint, scene.particles, stepper.save_state(), history.str()});
  };

  // The last state known to be sound, for a blow-up report.
  Particles last_good;
  keep_last_good(scene.particles, last_good);
  const std::size_t n = scene.particles.size();
  Progress progress(log, options.quiet, stepper.step_count(), steps, n);
  // Stops the run on a blow-up: the history so far stays, the last good state is written.
  const auto stop_on_blow_up = [&](const BlowUpError& e) {
    progress.finish();
    write_final_state(last_good, (directory / "last_good_state.csv").string());
    std::ostringstream message;
    message << e.what() << ". Likely cause: ";
    // Blame the time step only when it is above its limit (--unsafe-time-step).
    if (description.time_step > recommended) {
      message << "time.step = " << description.time_step << " s above its limit " << recommended
              << " s set by " << limit.cause << "; try a smaller step";
    } else if (e.cause() == BlowUpCause::kHeat) {
      message << "heat flows too fast for the explicit heat step, or an absurd temperature or "
                 "laser power; lower time.step or check the thermal properties and the laser";
    } else if (e.cause() == BlowUpCause::kTool) {
      message
          << "the tool named above drives particles into each other or a wall faster than "
             "the contacts push back (time.step is within its limit); slow it or check its path";
    } else if (e.cause() == BlowUpCause::kHistory) {
      message << "a total too large for a double: check the initial velocities, temperatures and "
                 "material properties for absurd values";
    } else {
      message << "initial overlaps, a stiff material or a wall cutting particles (time.step is "
                 "within its limit "
              << recommended << " s)";
    }
    message << ". Last good state: " << (directory / "last_good_state.csv").string();
    throw BlowUpError(message.str(), e.cause());
  };
  if (stepper.step_count() == 0) {
    try {
      record();
    } catch (const BlowUpError& e) {
      stop_on_blow_up(e);
    }
    if (vtk) vtk->write(scene, stepper);
  }
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  const std::int64_t first_step = stepper.step_count();
  for (std::int64_t s = first_step + 1; s <= steps; ++s) {
    try {
      stepper.step();
      if (s % history_every == 0 || s == steps) {
        record();
        keep_last_good(scene.particles, last_good);
      }
    } catch (const BlowUpError& e) {
      stop_on_blow_up(e);
    }
    if (vtk && (s % vtk_every == 0 || s == steps)) vtk->write(scene, stepper);
    if (s % checkpoint_every == 0 && s != steps) checkpoint();
    progress.update(s, stepper.time());
    if (options.stop_requested != nullptr && *options.stop_requested != 0 && s != steps) {
      progress.finish();
      // A frame of the state reached, to look at; a restart drops it (an uninterrupted run has
      // no frame here).
      if (vtk && s % vtk_every != 0) vtk->write(scene, stepper);
      checkpoint();  // first: final_state.csv never appears without the checkpoint of its state
      write_final_state(scene.particles, (directory / "final_state.csv").string(),
                        bond_counts(scene.particles, stepper));
      std::ostringstream message;
      message << "interrupted at step " << s << " (t = " << stepper.time()
              << " s); checkpoint written. Resume with: "
              << resume_command(options, description, directory, checkpoint_path);
      throw RunInterrupted(message.str());
    }
  }
  progress.finish();
  const double wall_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  checkpoint();  // first: the end-of-run files never appear without the checkpoint of their state
  OutputSet end_of_run(
      {directory / "final_state.csv", directory / "clusters.csv", directory / "layer.csv"});
  write_final_state(scene.particles, (directory / "final_state.csv").string(),
                    bond_counts(scene.particles, stepper));

  RunResult result;
  result.steps = steps - first_step;
  result.particles = n;
  result.threads = threads_in_use(n);
  result.wall_seconds = wall_seconds;
  result.particle_steps_per_second =
      wall_seconds > 0.0 ? static_cast<double>(result.steps) * static_cast<double>(n) / wall_seconds
                         : 0.0;
  result.neighbor_builds = stepper.neighbors().build_count();
  result.contacts = stepper.contacts();
  double max_radius = 0.0;
  for (const double r : scene.particles.radius) max_radius = std::max(max_radius, r);
  result.packing_region =
      description.analysis_region
          ? *description.analysis_region
          : bed_region(scene.particles, Box{scene.domain.min, scene.domain.max}, 4.0 * max_radius);
  result.packing =
      analyse_packing(scene.particles, stepper.neighbors(), result.packing_region, scene.domain);

  // Clusters: bonded agglomerates of two or more particles (the rows of clusters.csv, numbered
  // 0..K-1), and their size distribution against the primary particles'. Particles with no bond
  // are counted apart, as unbonded.
  const Particles& p = scene.particles;
  const NeighborList& list = stepper.neighbors();
  std::vector<std::pair<std::uint32_t, std::uint32_t>> bonded;
  list.for_each_pair([&](std::size_t i, std::size_t j, std::uint32_t k) {
    if (stepper.pair_forces().bonded[k] != 0) {
      bonded.emplace_back(static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(j));
    }
  });
  const ClusterReport clusters = find_clusters(p, bonded);
  std::vector<double> primary, agglomerates;
  for (const double r : p.radius) primary.push_back(2.0 * r);
  AtomicFile cluster_file((directory / "clusters.csv").string());
  cluster_file.stream() << "cluster,particles,volume_equivalent_diameter\n";
  for (std::size_t k = 0; k < clusters.sizes.size(); ++k) {
    if (clusters.sizes[k] < 2) {
      ++result.unbonded;
      continue;
    }
    result.largest_cluster = std::max(result.largest_cluster, clusters.sizes[k]);
    cluster_file.stream() << agglomerates.size() << ',' << clusters.sizes[k] << ','
                          << exact(clusters.volume_equivalent_diameters[k]) << '\n';
    agglomerates.push_back(clusters.volume_equivalent_diameters[k]);
  }
  cluster_file.commit();
  result.clusters = agglomerates.size();
  result.primary_sizes = size_quantiles(primary);
  result.cluster_sizes = size_quantiles(agglomerates);

  result.bonds_formed = stepper.bonds_formed();
  result.bonds_broken = stepper.bonds_broken();
  if (p.thermal()) {
    ThermalReport thermal;
    thermal.laser_energy = stepper.laser_energy();
    thermal.laser_missed = stepper.laser_missed();
    thermal.final_max_temperature = *std::max_element(p.temperature.begin(), p.temperature.end());
    thermal.clusters_of_two_or_more = agglomerates.size();
    // The heat-affected band: particles that reached the bonding temperature (or, without that
    // criterion, the hottest tenth of the temperature rise).
    double threshold = description.bond.temperature;
    if (description.bond.criterion != BondCriterion::kTemperature) {
      const double initial = description.thermal->initial_temperature;
      double peak = initial;
      for (const double t : p.peak_temperature) peak = std::max(peak, t);
      threshold = initial + 0.9 * (peak - initial);
    }
    thermal.threshold = threshold;
    if (description.laser) {
      thermal.track = measure_track(p, *description.laser, threshold);
    } else {
      for (const double t : p.peak_temperature) {
        thermal.track.peak_temperature = std::max(thermal.track.peak_temperature, t);
      }
    }
    result.thermal = thermal;
  }

  if (description.layer) {
    result.layer = measure_layer(p, *description.layer);
    AtomicFile layer_file((directory / "layer.csv").string());
    layer_file.stream() << "x,solid_fraction\n";
    for (std::size_t b = 0; b < result.layer->bin_x_center.size(); ++b) {
      layer_file.stream() << exact(result.layer->bin_x_center[b]) << ','
                          << exact(result.layer->bin_solid_fraction[b]) << '\n';
    }
    layer_file.commit();
  }
  end_of_run.keep();
  return result;
}

}  // namespace bondem
