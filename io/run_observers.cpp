#include "io/run_observers.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <system_error>
#include <utility>

#include "io/atomic_file.hpp"
#include "io/checkpoint.hpp"

namespace bondem {

void write_final_state(const Particles& p, const std::string& path, const std::vector<int>& bonds) {
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
    out << p.id[i] << ',' << exact_text(p.x[i]) << ',' << exact_text(p.y[i]) << ','
        << exact_text(p.z[i]) << ',' << exact_text(p.vx[i]) << ',' << exact_text(p.vy[i]) << ','
        << exact_text(p.vz[i]) << ',' << exact_text(p.radius[i]);
    if (thermal) {
      out << ',' << exact_text(p.temperature[i]) << ',' << exact_text(p.peak_temperature[i]) << ','
          << bonds[i];
    }
    out << '\n';
  }
  file.commit();
}

HistoryFile::HistoryFile(std::string path)
    : path_(std::move(path)), stream_(path_, std::ios::binary | std::ios::trunc) {}

void HistoryFile::append(const std::string& text) {
  stream_ << text << std::flush;
  if (!stream_) throw std::runtime_error(path_ + ": write failed");
}

LastGoodFile::LastGoodFile(std::string path, const Particles& particles, const History& history)
    : path_(std::move(path)), history_(history) {
  keep_last_good(particles, state_);
}

void LastGoodFile::after_step(const Simulation& simulation) {
  // A state is good once its history row is written: every value in it was finite.
  if (history_.last_row_step() == simulation.step()) {
    keep_last_good(simulation.scene().particles, state_);
  }
}

void LastGoodFile::interrupted(const Simulation& /*simulation*/, const Interruption& why) {
  if (why.reason == StopReason::kBlowUp) write_final_state(state_, path_);
}

VtkFrames::VtkFrames(const std::filesystem::path& directory, std::int64_t every)
    : every_(every), writer_(directory.string()) {}

void VtkFrames::resume(const Scene& scene, std::int64_t checkpoint_step, double time_step) {
  writer_.resume(
      [&](double time) {
        const std::int64_t step = std::llround(time / time_step);
        return step <= checkpoint_step && step % every_ == 0;
      },
      scene.boundaries, scene.domain);
}

void VtkFrames::start(const Simulation& simulation) {
  if (simulation.step() == 0) write(simulation.scene(), simulation.stepper());
}

void VtkFrames::after_step(const Simulation& simulation) {
  if (every_or_last(simulation, every_)) write(simulation.scene(), simulation.stepper());
}

void VtkFrames::interrupted(const Simulation& simulation, const Interruption& why) {
  // A frame of the state reached, to look at; a restart drops it (an uninterrupted run has no
  // frame here).
  if (why.reason == StopReason::kStopRequested && simulation.step() % every_ != 0) {
    write(simulation.scene(), simulation.stepper());
  }
}

void VtkFrames::write(const Scene& scene, const Stepper& stepper) {
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
  // The particles' own fields come from their table; only the per-frame derived arrays are passed.
  writer_.write_frame(stepper.time(), p, contacts_, scene.boundaries, scene.domain,
                      {{"coordination", &coordination_}, {"bond_count", &bond_count_}});
}

CheckpointFile::CheckpointFile(std::string path, std::uint64_t fingerprint, std::int64_t every,
                               const History& history)
    : path_(std::move(path)), fingerprint_(fingerprint), every_(every), history_(history) {}

void CheckpointFile::after_step(const Simulation& simulation) {
  // Not at the end: finish() writes that one, after the last step's other outputs.
  if (simulation.step() % every_ == 0 && !simulation.at_end()) write(simulation);
}

void CheckpointFile::interrupted(const Simulation& simulation, const Interruption& why) {
  if (why.reason == StopReason::kStopRequested) write(simulation);
}

void CheckpointFile::finish(const Simulation& simulation) {
  write(simulation);
}

void CheckpointFile::write(const Simulation& simulation) const {
  // By reference: the particles are streamed to the file, not copied.
  const StepperState state = simulation.stepper().save_state();
  write_checkpoint(
      path_, CheckpointView{fingerprint_, simulation.scene().particles, state, history_.text()});
}

namespace {

/// Files that appear together or not at all. Removes the ones listed unless kept (an exception
/// between the first write and keep() leaves none behind).
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
  OutputSet(OutputSet&&) = delete;
  OutputSet& operator=(OutputSet&&) = delete;
  void keep() { kept_ = true; }

 private:
  std::vector<std::filesystem::path> paths_;
  bool kept_ = false;
};

/// clusters.csv: one row per agglomerate (two or more particles), numbered 0..K-1.
void write_clusters(const ClusterReport& clusters, const std::string& path) {
  AtomicFile file(path);
  file.stream() << "cluster,particles,volume_equivalent_diameter\n";
  std::size_t row = 0;
  for (std::size_t k = 0; k < clusters.sizes.size(); ++k) {
    if (clusters.sizes[k] < 2) continue;
    file.stream() << row++ << ',' << clusters.sizes[k] << ','
                  << exact_text(clusters.volume_equivalent_diameters[k]) << '\n';
  }
  file.commit();
}

/// layer.csv: the solid fraction per bin along x.
void write_layer(const LayerMetrics& layer, const std::string& path) {
  AtomicFile file(path);
  file.stream() << "x,solid_fraction\n";
  for (std::size_t b = 0; b < layer.bin_x_center.size(); ++b) {
    file.stream() << exact_text(layer.bin_x_center[b]) << ','
                  << exact_text(layer.bin_solid_fraction[b]) << '\n';
  }
  file.commit();
}

}  // namespace

EndOfRunFiles::EndOfRunFiles(std::filesystem::path directory, const RunAnalysis& analysis)
    : directory_(std::move(directory)), analysis_(analysis) {}

void EndOfRunFiles::interrupted(const Simulation& simulation, const Interruption& why) {
  if (why.reason != StopReason::kStopRequested) return;
  const Particles& p = simulation.scene().particles;
  write_final_state(p, (directory_ / "final_state.csv").string(),
                    bond_counts(p, simulation.stepper()));
}

void EndOfRunFiles::finish(const Simulation& simulation) {
  if (!analysis_.figures()) throw std::logic_error("EndOfRunFiles: attach it after RunAnalysis");
  const RunFigures& figures = *analysis_.figures();
  OutputSet end_of_run(
      {directory_ / "final_state.csv", directory_ / "clusters.csv", directory_ / "layer.csv"});
  const Particles& p = simulation.scene().particles;
  write_final_state(p, (directory_ / "final_state.csv").string(),
                    bond_counts(p, simulation.stepper()));
  write_clusters(figures.clusters, (directory_ / "clusters.csv").string());
  if (figures.layer) write_layer(*figures.layer, (directory_ / "layer.csv").string());
  end_of_run.keep();
}

}  // namespace bondem
