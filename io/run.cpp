#include "io/run.hpp"

#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <numeric>
#include <optional>
#include <ostream>
#include <sstream>

#include "io/atomic_file.hpp"
#include "io/case_file.hpp"
#include "io/checkpoint.hpp"
#include "io/vtk_output.hpp"
#include "solver/calculator.hpp"
#include "solver/scene.hpp"
#include "solver/stepper.hpp"

namespace bondem {
namespace {

/// Shortest exact text of a double: the same bits always give the same bytes.
std::string exact(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.17g", value);
  return buffer;
}

/// Columns of history.csv; each wall and tool adds the force the particles exert on it.
std::string history_header(const Scene& scene) {
  std::string header =
      "time,kinetic_energy,rotational_energy,contacts,bonds,bonds_formed,bonds_broken,"
      "wall_contacts,max_overlap";
  if (scene.particles.thermal()) header += ",max_temperature,mean_temperature,laser_energy";
  const auto add_load = [&](const std::string& name) {
    for (const char* axis : {"_x", "_y", "_z"}) header += ",load_" + name + axis;
  };
  for (const PlaneWall& wall : scene.walls) add_load(wall.name);
  for (const Body& body : scene.bodies) add_load(body.name);
  return header + '\n';
}

/// Bonds per particle in the last force evaluation.
std::vector<int> bond_counts(const Particles& p, const Stepper& stepper) {
  std::vector<int> counts(p.size(), 0);
  const NeighborList& list = stepper.neighbors();
  for (std::size_t i = 0; i < p.size(); ++i) {
    for (std::uint32_t k = list.row_begin[i]; k < list.row_begin[i + 1]; ++k) {
      if (stepper.pair_forces().bonded[k] == 0) continue;
      ++counts[i];
      ++counts[list.second[k]];
    }
  }
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

/// Copies into @p to the fields write_final_state reads (ids, positions, velocities, radii): the
/// last good state kept for a blow-up, at about a third of the memory of a full copy.
void keep_last_good(const Particles& from, Particles& to) {
  to.id = from.id;
  to.x = from.x;
  to.y = from.y;
  to.z = from.z;
  to.vx = from.vx;
  to.vy = from.vy;
  to.vz = from.vz;
  to.radius = from.radius;
}

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

  void resume(double time) { writer_.resume(time); }

  void write(const Scene& scene, const Stepper& stepper) {
    const Particles& p = scene.particles;
    const NeighborList& list = stepper.neighbors();
    const PairForces& forces = stepper.pair_forces();
    coordination_.assign(p.size(), 0.0);
    bond_count_.assign(p.size(), 0.0);
    contacts_.clear();
    for (std::size_t i = 0; i < p.size(); ++i) {
      for (std::uint32_t k = list.row_begin[i]; k < list.row_begin[i + 1]; ++k) {
        const std::size_t j = list.second[k];
        const Eigen::Vector3d& shift = list.shifts[list.image[k]];
        const Eigen::Vector3d first(p.x[i], p.y[i], p.z[i]);
        const Eigen::Vector3d second =
            Eigen::Vector3d(p.x[j], p.y[j], p.z[j]) + shift;  // the image seen from i
        const Eigen::Vector3d d = second - first;
        const double overlap = p.radius[i] + p.radius[j] - d.norm();
        if (overlap <= 0.0) continue;
        const Eigen::Vector3d force(forces.fx[k], forces.fy[k], forces.fz[k]);
        const bool bonded = forces.bonded[k] != 0;
        contacts_.push_back(
            {p.id[i], p.id[j], first, second, overlap, force.dot(d.normalized()), bonded});
        coordination_[i] += 1.0;
        coordination_[j] += 1.0;
        bond_count_[i] += bonded ? 1.0 : 0.0;
        bond_count_[j] += bonded ? 1.0 : 0.0;
      }
    }
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
  const double recommended = case_time_step_limit(description);
  if (options.enforce_time_step_limit && description.time_step > recommended) {
    std::ostringstream message;
    message << description.source << ": 'time.step': " << description.time_step
            << " s is above the recommended " << recommended
            << " s (min of t_contact/50, T_bond/50, 0.2 T_Rayleigh; see bondem info); "
               "lower time.step (or --unsafe-time-step)";
    throw CaseError(message.str());
  }
  const std::filesystem::path directory =
      options.output_directory.empty() ? description.output_directory : options.output_directory;
  const std::string checkpoint_path = (directory / "checkpoint.bin").string();
  const std::uint64_t fingerprint = case_fingerprint(description);

  Scene scene = build_scene(description);
  std::ostringstream history;
  std::optional<Stepper> stepper_storage;
  if (options.restart_path.empty()) {
    stepper_storage.emplace(scene);
    history << history_header(scene);
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
    scene.particles = std::move(restored.particles);
    stepper_storage.emplace(scene, restored.stepper);
    history << restored.history;
  }
  Stepper& stepper = *stepper_storage;

  const auto steps =
      static_cast<std::int64_t>(std::llround(description.end_time / description.time_step));
  const auto every = [&](double interval, double fallback) {
    return std::max<std::int64_t>(
        1, std::llround((interval > 0.0 ? interval : fallback) / description.time_step));
  };
  const std::int64_t history_every =
      every(description.history_interval, description.end_time / 100.0);
  const std::int64_t vtk_every = every(description.vtk_interval, 2.0 * description.end_time);
  std::optional<VtkObserver> vtk;
  if (description.vtk_interval > 0.0) {
    vtk.emplace(directory);
    if (stepper.step_count() > 0) vtk->resume(stepper.time());
  }
  const std::int64_t checkpoint_every =
      every(description.checkpoint_interval, 2.0 * description.end_time);

  const auto record = [&] {
    const ContactSummary& c = stepper.contacts();
    history << exact(stepper.time()) << ',' << exact(stepper.kinetic_energy()) << ','
            << exact(stepper.rotational_energy()) << ',' << c.contacts << ',' << c.bonds << ','
            << stepper.bonds_formed() << ',' << stepper.bonds_broken() << ',' << c.wall_contacts
            << ',' << exact(c.max_overlap);
    if (scene.particles.thermal()) {
      const std::vector<double>& t = scene.particles.temperature;
      double sum = 0.0;
      for (const double value : t) sum += value;  // index order: the same bytes at any thread count
      history << ',' << exact(*std::max_element(t.begin(), t.end())) << ','
              << exact(sum / static_cast<double>(t.size())) << ',' << exact(stepper.laser_energy());
    }
    for (const Eigen::Vector3d& load : stepper.wall_forces()) {
      history << ',' << exact(load.x()) << ',' << exact(load.y()) << ',' << exact(load.z());
    }
    history << '\n';
  };
  const auto write_history = [&] {
    AtomicFile file((directory / "history.csv").string());
    file.stream() << history.str();
    file.commit();
  };
  const auto checkpoint = [&] {
    write_checkpoint(checkpoint_path,
                     {fingerprint, scene.particles, stepper.save_state(), history.str()});
  };
  if (stepper.step_count() == 0) {
    record();
    if (vtk) vtk->write(scene, stepper);
  }

  // The last state known to be sound, for a blow-up report.
  Particles last_good;
  keep_last_good(scene.particles, last_good);
  const std::size_t n = scene.particles.size();
  Progress progress(log, options.quiet, stepper.step_count(), steps, n);
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  const std::int64_t first_step = stepper.step_count();
  for (std::int64_t s = first_step + 1; s <= steps; ++s) {
    try {
      stepper.step();
    } catch (const BlowUpError& e) {
      progress.finish();
      write_history();
      write_final_state(last_good, (directory / "last_good_state.csv").string());
      std::ostringstream message;
      message << e.what() << ". Likely cause: ";
      if (description.time_step > 0.5 * recommended) {
        message << "time.step = " << description.time_step << " s against the recommended "
                << recommended << " s; try a smaller step";
      } else {
        message << "initial overlaps, a stiff material or a wall cutting particles";
      }
      message << ". Last good state: " << (directory / "last_good_state.csv").string();
      throw BlowUpError(message.str());
    }
    if (s % history_every == 0 || s == steps) {
      record();
      keep_last_good(scene.particles, last_good);
    }
    if (vtk && (s % vtk_every == 0 || s == steps)) vtk->write(scene, stepper);
    if (s % checkpoint_every == 0 && s != steps) checkpoint();
    progress.update(s, stepper.time());
    if (options.stop_requested != nullptr && *options.stop_requested != 0 && s != steps) {
      progress.finish();
      if (vtk && s % vtk_every != 0) vtk->write(scene, stepper);
      checkpoint();
      write_history();
      write_final_state(scene.particles, (directory / "final_state.csv").string(),
                        bond_counts(scene.particles, stepper));
      std::ostringstream message;
      // A built-in case has no file to name: `bondem run` without one picks it again.
      const std::string case_argument =
          description.source.rfind('<', 0) == 0 ? "" : description.source + " ";
      message << "interrupted at step " << s << " (t = " << stepper.time()
              << " s); checkpoint written. Resume with: bondem run " << case_argument << "--output "
              << directory.string() << " --restart " << checkpoint_path
              << " (and the same --set options, if any)";
      throw RunInterrupted(message.str());
    }
  }
  progress.finish();
  const double wall_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  write_history();
  write_final_state(scene.particles, (directory / "final_state.csv").string(),
                    bond_counts(scene.particles, stepper));
  checkpoint();

  RunResult result;
  result.steps = steps - first_step;
  result.particles = n;
  result.threads = omp_get_max_threads();
  result.wall_seconds = wall_seconds;
  result.particle_steps_per_second =
      wall_seconds > 0.0 ? static_cast<double>(result.steps) * static_cast<double>(n) / wall_seconds
                         : 0.0;
  result.neighbor_builds = stepper.neighbors().builds;
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
  for (std::size_t i = 0; i < p.size(); ++i) {
    for (std::uint32_t k = list.row_begin[i]; k < list.row_begin[i + 1]; ++k) {
      if (stepper.pair_forces().bonded[k] != 0) {
        bonded.emplace_back(static_cast<std::uint32_t>(i), list.second[k]);
      }
    }
  }
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
  return result;
}

}  // namespace bondem
