#include "io/run_observers.hpp"

#include <fcntl.h>
#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <system_error>
#include <utility>
#include <variant>

#include "io/atomic_file.hpp"
#include "io/checkpoint.hpp"

namespace bondem {

namespace {

/// Characters of a 64-bit integer at most: -9223372036854775808.
constexpr std::size_t kIntegerChars = 21;
/// Characters of a final-state row at most, besides the material's name: id, twelve values and a
/// bond count, with separators.
constexpr std::size_t kFinalRowChars = 2 * kIntegerChars + 12 * kExactTextChars + 15;

/// The final-state rows of particles order[first, last) at @p out, which has room for
/// kFinalRowChars plus the longest of @p names per row; returns the end.
char* write_final_rows(const Particles& p, const std::vector<std::string>& names,
                       const std::vector<std::uint32_t>& order, std::size_t first, std::size_t last,
                       const std::vector<int>& bonds, bool thermal, char* out) {
  const auto put = [&out](double value) {
    *out++ = ',';
    out = write_exact_text(out, value);
  };
  for (std::size_t row = first; row < last; ++row) {
    const std::uint32_t i = order[row];
    out = std::to_chars(out, out + kIntegerChars, p.id[i]).ptr;
    for (const double value : {p.x[i], p.y[i], p.z[i], p.vx[i], p.vy[i], p.vz[i], p.radius[i]}) {
      put(value);
    }
    if (thermal) {
      put(p.temperature[i]);
      put(p.peak_temperature[i]);
      *out++ = ',';
      out = std::to_chars(out, out + kIntegerChars, bonds[i]).ptr;
    }
    const std::string& name = names[static_cast<std::size_t>(p.material[i])];
    *out++ = ',';
    out = std::copy(name.begin(), name.end(), out);
    for (const double value : {p.wx[i], p.wy[i], p.wz[i]}) put(value);
    *out++ = '\n';
  }
  return out;
}

/// write_final_state() into @p file, which the caller commits.
void put_final_state(AtomicFile& file, const Particles& p,
                     const std::vector<std::string>& material_names,
                     const std::vector<int>& bonds) {
  const std::vector<std::uint32_t> order = p.order_by_id();
  std::ostream& out = file.stream();
  const bool thermal = p.thermal() && bonds.size() == p.size();
  // New columns go last, so that a reader by column position keeps working.
  out << "id,x,y,z,vx,vy,vz,radius" << (thermal ? ",temperature,peak_temperature,bonds" : "")
      << ",material,wx,wy,wz\n";
  std::size_t longest_name = 0;
  for (const std::string& name : material_names) longest_name = std::max(longest_name, name.size());
  const std::size_t row_chars = kFinalRowChars + longest_name;
  // Formatting 17 digits is most of the time (10^6 rows, 7 million values): blocks of rows are
  // formatted on every thread and written in order, one thread's block while the others format
  // their next ones. The bytes do not depend on the threads. A block's text (about 700 kB) stays in
  // the core's L2 between its formatting and its write, and its buffer is neither zeroed nor
  // faulted in again for every block. One parallel region for the file: a region per round of
  // blocks, its writes on the master while the other threads waited, made two threads slower than
  // one at 10^6 (0.33 s against 0.23 s).
  constexpr std::size_t kBlockRows = 2048;
  const std::size_t rows = order.size();
  const std::size_t blocks = (rows + kBlockRows - 1) / kBlockRows;
  const auto threads = static_cast<std::size_t>(threads_in_use(rows));
  std::vector<std::unique_ptr<char[]>> text(threads);
  for (auto& buffer : text)
    buffer = std::make_unique_for_overwrite<char[]>(std::min(rows, kBlockRows) * row_chars);
#pragma omp parallel num_threads(static_cast <int>(threads)) if (threads > 1)
  {
    char* const start = text[static_cast<std::size_t>(omp_get_thread_num())].get();
#pragma omp for ordered schedule(static, 1)
    for (std::size_t block = 0; block < blocks; ++block) {
      const std::size_t begin = block * kBlockRows;
      const char* const end =
          write_final_rows(p, material_names, order, begin, std::min(rows, begin + kBlockRows),
                           bonds, thermal, start);
#pragma omp ordered
      out.write(start, end - start);
    }
  }
}

}  // namespace

void write_final_state(const Particles& p, const std::vector<std::string>& material_names,
                       const std::string& path, const std::vector<int>& bonds) {
  AtomicFile file(path);
  put_final_state(file, p, material_names, bonds);
  file.commit();
}

namespace {

/// `<prefix><index, zero-padded to digits>.csv`.
std::string numbered_file_name(std::string_view prefix, int digits, std::int64_t index) {
  char number[32];
  std::snprintf(number, sizeof number, "%0*lld", digits, static_cast<long long>(index));
  return std::string(prefix) + number + ".csv";
}

/// The index of a numbered_file_name() of @p prefix and @p digits, or -1 for another name.
std::int64_t numbered_file_index(const std::string& name, std::string_view prefix, int digits) {
  constexpr std::string_view kSuffix = ".csv";
  if (name.size() < prefix.size() + static_cast<std::size_t>(digits) + kSuffix.size() ||
      name.rfind(prefix, 0) != 0 ||
      name.compare(name.size() - kSuffix.size(), kSuffix.size(), kSuffix) != 0) {
    return -1;
  }
  const std::string_view number(name.data() + prefix.size(),
                                name.size() - prefix.size() - kSuffix.size());
  std::int64_t index = -1;
  const auto [end, error] = std::from_chars(number.data(), number.data() + number.size(), index);
  if (error != std::errc() || end != number.data() + number.size() || index < 0) return -1;
  return numbered_file_name(prefix, digits, index) == name ? index : -1;
}

}  // namespace

std::string state_file_name(std::int64_t index) {
  return numbered_file_name("state_", 6, index);
}

std::int64_t state_file_index(const std::string& name) {
  return numbered_file_index(name, "state_", 6);
}

std::string layer_file_name(std::int64_t number) {
  return numbered_file_name("layer_", 3, number);
}

std::int64_t layer_file_number(const std::string& name) {
  const std::int64_t number = numbered_file_index(name, "layer_", 3);
  return number >= 1 ? number : -1;
}

HistoryFile::HistoryFile(std::string path)
    : path_(std::move(path)), stream_(path_, std::ios::binary | std::ios::trunc) {}

void HistoryFile::append(const std::string& text) {
  stream_ << text << std::flush;
  if (!stream_) throw std::runtime_error(path_ + ": write failed");
}

namespace {

/// The scratch file of a LastGoodFile writing @p path: hidden, beside it, named like the
/// temporaries remove_stale_outputs() clears (it is unlinked at once; a name can be left only by
/// a kill between its creation and its unlinking).
std::filesystem::path last_good_scratch(const std::string& path, const std::string& tag) {
  return std::filesystem::path(path).parent_path() /
         (std::string(kLastGoodScratch) + tag + ".tmp." + std::to_string(::getpid()));
}

}  // namespace

LastGoodFile::LastGoodFile(std::string path, const Particles& particles, const History& history,
                           const std::string& scratch_tag)
    : path_(std::move(path)), history_(history) {
  const std::filesystem::path scratch = last_good_scratch(path_, scratch_tag);
  scratch_ = ::open(scratch.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (scratch_ < 0) throw std::runtime_error(scratch.string() + ": cannot open for writing");
  // The open descriptor keeps the file; its name is not needed any more.
  std::error_code ignored;
  std::filesystem::remove(scratch, ignored);
  try {
    keep(particles);
  } catch (...) {
    ::close(scratch_);  // no destructor runs for an object whose constructor throws
    throw;
  }
}

LastGoodFile::~LastGoodFile() {
  ::close(scratch_);
}

void LastGoodFile::keep(const Particles& particles, const std::vector<std::uint32_t>* rows) {
  // Through a FileWriteBuffer (on a copy of the descriptor, which it closes): 64 MB at 10^6
  // particles, written past the page cache.
  const int copy = ::dup(scratch_);
  if (copy < 0) throw std::runtime_error(path_ + ": cannot keep the last good state (dup failed)");
  FileWriteBuffer buffer(copy);
  std::ostream scratch(&buffer);
  const auto count = static_cast<std::uint64_t>(rows != nullptr ? rows->size() : particles.size());
  scratch.write(reinterpret_cast<const char*>(&count), sizeof count);
  for (const ParticleField& field : kParticleFields) {
    if (!has(field, kLastGood)) continue;
    std::visit(
        [&](auto member) {
          const auto& values = particles.*member;
          if (rows == nullptr) {
            scratch.write(reinterpret_cast<const char*>(values.data()),
                          static_cast<std::streamsize>(values.size() * sizeof values[0]));
            return;
          }
          // kLastGood fields hold one value a particle (unused ones none).
          if (values.empty()) return;
          std::vector<std::decay_t<decltype(values[0])>> chosen;
          chosen.reserve(rows->size());
          for (const std::uint32_t row : *rows) chosen.push_back(values[row]);
          scratch.write(reinterpret_cast<const char*>(chosen.data()),
                        static_cast<std::streamsize>(chosen.size() * sizeof chosen[0]));
        },
        field.member);
  }
  if (!scratch || !buffer.finish())
    throw std::runtime_error(path_ + ": cannot keep the last good state (write failed)");
}

Particles LastGoodFile::kept() {
  std::size_t offset = 0;
  bool read = true;
  const auto read_next = [&](void* data, std::size_t size) {
    for (std::size_t done = 0; read && done < size;) {
      const ssize_t got = ::pread(scratch_, static_cast<char*>(data) + done, size - done,
                                  static_cast<off_t>(offset + done));
      if (got < 0 && errno == EINTR) continue;
      if (got <= 0) read = false;
      done += got > 0 ? static_cast<std::size_t>(got) : 0;
    }
    offset += size;
  };
  std::uint64_t count = 0;
  read_next(&count, sizeof count);
  Particles state;
  for (const ParticleField& field : kParticleFields) {
    if (!has(field, kLastGood)) continue;
    std::visit(
        [&](auto member) {
          auto& values = state.*member;
          values.resize(count);
          read_next(values.data(), values.size() * sizeof values[0]);
        },
        field.member);
  }
  if (!read) throw std::runtime_error(path_ + ": cannot read the last good state back");
  return state;
}

void LastGoodFile::after_step(const Simulation& simulation) {
  // A state is good once its history row is written: every value in it was finite. After the
  // last step no step can blow up: that state would never be read.
  if (history_.last_row_step() == simulation.step() && !simulation.at_end()) {
    keep(simulation.scene().particles);
  }
}

void LastGoodFile::interrupted(const Simulation& simulation, const Interruption& why) {
  if (why.reason == StopReason::kBlowUp) {
    write_final_state(kept(), simulation.scene().material_names, path_);
  }
}

const std::vector<std::string>& VtkFrames::derived_arrays() {
  static const std::vector<std::string> names{"coordination", "bond_count", "diameter"};
  return names;
}

VtkFrames::VtkFrames(const std::filesystem::path& directory, std::int64_t every,
                     std::vector<std::string> fields)
    : every_(every), writer_(directory.string()) {
  writer_.select_particle_arrays(std::move(fields));
}

void VtkFrames::describe(const Scene& scene) {
  writer_.set_material_names(scene.material_names);
  // A bonds series where some pair of materials can bond.
  writer_.set_bonds_series(some_pair_can_bond(scene));
}

void VtkFrames::resume(const Scene& scene, std::int64_t checkpoint_step, double time_step) {
  describe(scene);
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
  if (reads_state(simulation, simulation.step())) write(simulation.scene(), simulation.stepper());
}

void VtkFrames::interrupted(const Simulation& simulation, const Interruption& why) {
  // A frame of the state reached, to look at; a restart drops it (an uninterrupted run has no
  // frame here).
  if (why.reason == StopReason::kStopRequested && simulation.step() % every_ != 0) {
    write(simulation.scene(), simulation.stepper());
  }
}

void frame_contacts(const Scene& scene, const Stepper& stepper, std::vector<double>& coordination,
                    std::vector<double>& bond_count,
                    const std::function<void(std::size_t, const ContactRecord&)>& contact) {
  const Particles& p = scene.particles;
  const NeighborList& list = stepper.neighbors();
  const PairForces& forces = stepper.pair_forces();
  coordination.assign(p.size(), 0.0);
  bond_count.assign(p.size(), 0.0);
  list.for_each_pair([&](std::size_t i, std::size_t j, std::uint32_t k) {
    // The end points are written to the file: the image of j is formed as a point first.
    const Eigen::Vector3d first(p.x[i], p.y[i], p.z[i]);
    const Eigen::Vector3d second = Eigen::Vector3d(p.x[j], p.y[j], p.z[j]) + list.shift(k);
    const Eigen::Vector3d d = second - first;
    const double overlap = p.radius[i] + p.radius[j] - d.norm();
    if (overlap <= 0.0) return;
    const Eigen::Vector3d force = forces.force(k);
    const bool bonded = forces.bonded[k] != 0;
    contact(i,
            {p.id[i], p.id[j], first, second, overlap, force.dot(d.normalized()), bonded, force});
    coordination[i] += 1.0;
    coordination[j] += 1.0;
    bond_count[i] += bonded ? 1.0 : 0.0;
    bond_count[j] += bonded ? 1.0 : 0.0;
  });
}

void VtkFrames::write(const Scene& scene, const Stepper& stepper) {
  describe(scene);
  const Particles& p = scene.particles;
  diameter_.resize(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) diameter_[i] = 2.0 * p.radius[i];
  std::vector<BoundaryLoadRecord> loads;
  const std::vector<BoundaryLoad> totals = stepper.boundary_loads();
  for (std::size_t b = 0; b < totals.size(); ++b) {
    loads.push_back({scene.boundaries[b].name, totals[b].force, totals[b].moment});
  }
  writer_.set_boundary_loads(std::move(loads));
  contacts_.clear();
  frame_contacts(scene, stepper, coordination_, bond_count_,
                 [&](std::size_t, const ContactRecord& record) { contacts_.push_back(record); });
  // By ids (id_i < id_j: each pair is seen from its smaller id), not in the storage order.
  std::sort(contacts_.begin(), contacts_.end(), [](const ContactRecord& a, const ContactRecord& b) {
    return a.id_i != b.id_i ? a.id_i < b.id_i : a.id_j < b.id_j;
  });
  // The particles' own fields come from their table; only the per-frame derived arrays are passed.
  const std::vector<std::string>& derived = derived_arrays();
  writer_.write_frame(
      stepper.time(), p, contacts_, scene.boundaries, scene.domain,
      {{derived[0], &coordination_}, {derived[1], &bond_count_}, {derived[2], &diameter_}});
}

CheckpointFile::CheckpointFile(std::string path, std::uint64_t fingerprint, std::int64_t every,
                               const History& history)
    : path_(std::move(path)), fingerprint_(fingerprint), every_(every), history_(history) {}

void CheckpointFile::after_step(const Simulation& simulation) {
  // Not at the end: finish() writes that one, after the last step's other outputs.
  if (reads_state(simulation, simulation.step())) write(simulation.scene(), simulation.stepper());
}

void CheckpointFile::interrupted(const Simulation& simulation, const Interruption& why) {
  if (why.reason == StopReason::kStopRequested) write(simulation.scene(), simulation.stepper());
}

void CheckpointFile::finish(const Simulation& simulation) {
  // The scene and the stepper, not the simulation: they outlive it (a run that fails after this
  // unwinds the simulation first, and the future's destructor waits for the thread).
  const Scene& scene = simulation.scene();
  const Stepper& stepper = simulation.stepper();
  try {
    writing_ = std::async(std::launch::async, [this, &scene, &stepper] { write(scene, stepper); });
  } catch (const std::system_error&) {
    write(scene, stepper);  // no thread to be had: here, before the other end-of-run outputs
  }
}

void CheckpointFile::wait_written() {
  if (writing_.valid()) writing_.get();
}

void CheckpointFile::write(const Scene& scene, const Stepper& stepper) const {
  // By reference: the particles, the list's build positions and the pairs' state are streamed
  // to the file, not copied.
  const StepperState state = stepper.save_state(SavedArrays::kOmitted);
  write_checkpoint(path_, checkpoint_view(fingerprint_, scene.particles, stepper, state,
                                          history_.text(), scene.material_names));
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

namespace {

/// The bond counts a final state lists: those of a thermal run; none otherwise (4 B a particle
/// spared).
std::vector<int> final_state_bonds(const Simulation& simulation) {
  const Particles& p = simulation.scene().particles;
  return p.thermal() ? bond_counts(p, simulation.stepper()) : std::vector<int>{};
}

}  // namespace

StateFiles::StateFiles(std::filesystem::path directory, std::int64_t every)
    : directory_(std::move(directory)), every_(every) {}

void StateFiles::start(const Simulation& simulation) {
  if (simulation.step() == 0) write(simulation);
}

void StateFiles::after_step(const Simulation& simulation) {
  if (reads_state(simulation, simulation.step())) write(simulation);
}

void StateFiles::write(const Simulation& simulation) const {
  write_final_state(simulation.scene().particles, simulation.scene().material_names,
                    (directory_ / state_file_name(simulation.step() / every_)).string(),
                    final_state_bonds(simulation));
}

LayerFiles::LayerFiles(std::filesystem::path directory, const LayerSeries& series, double time_step)
    : directory_(std::move(directory)), series_(series), time_step_(time_step) {}

void LayerFiles::resume(std::int64_t checkpoint_step) {
  next_ = layers_through(series_, time_step_, checkpoint_step);
  const std::filesystem::path summary = directory_ / "layers.csv";
  if (next_ == 0) {
    std::error_code ignored;
    std::filesystem::remove(summary, ignored);
    return;
  }
  std::ifstream in(summary, std::ios::binary);
  std::string line;
  if (!std::getline(in, header_)) {
    throw std::runtime_error(summary.string() + ": missing or empty; the checkpoint follows " +
                             std::to_string(next_) + " measured layers, whose rows it must hold");
  }
  while (rows_.size() < next_ && std::getline(in, line)) rows_.push_back(line);
  if (rows_.size() < next_) {
    throw std::runtime_error(summary.string() + ": holds " + std::to_string(rows_.size()) +
                             " layer rows; the checkpoint follows " + std::to_string(next_));
  }
  write_summary();  // without the rows of layers measured after the checkpoint
}

void LayerFiles::after_step(const Simulation& simulation) {
  while (reads_state(simulation, simulation.step())) {
    const LayerSnapshot layer = measure_series_layer(series_, next_, simulation);
    ++next_;
    write_layer(layer.metrics, (directory_ / layer_file_name(layer.layer)).string());
    const LayerMetrics& m = layer.metrics;
    if (header_.empty()) {
      header_ =
          "layer,time,floor_z,base_z,particles,solid_fraction,mean_surface_height,roughness,"
          "max_surface_height,empty_fraction,bed_height";
      if (layer.agglomerates) header_ += ",agglomerates,largest_agglomerate";
    }
    std::ostringstream row;
    row << layer.layer << ',' << exact_text(layer.time) << ',' << exact_text(layer.floor_z) << ','
        << exact_text(layer.region.substrate_z) << ',' << m.particles << ','
        << exact_text(m.solid_fraction) << ',' << exact_text(m.mean_surface_height) << ','
        << exact_text(m.roughness) << ',' << exact_text(m.max_surface_height) << ','
        << exact_text(m.empty_fraction) << ','
        << exact_text(layer.region.substrate_z - layer.floor_z + m.mean_surface_height);
    if (layer.agglomerates) row << ',' << *layer.agglomerates << ',' << *layer.largest_agglomerate;
    rows_.push_back(row.str());
    write_summary();
  }
}

void LayerFiles::write_summary() const {
  AtomicFile file((directory_ / "layers.csv").string());
  file.stream() << header_ << '\n';
  for (const std::string& row : rows_) file.stream() << row << '\n';
  file.commit();
}

EndOfRunFiles::EndOfRunFiles(std::filesystem::path directory, const RunAnalysis& analysis,
                             CheckpointFile& checkpoint)
    : directory_(std::move(directory)), analysis_(analysis), checkpoint_(checkpoint) {}

void EndOfRunFiles::interrupted(const Simulation& simulation, const Interruption& why) {
  if (why.reason != StopReason::kStopRequested) return;
  const Particles& p = simulation.scene().particles;
  write_final_state(p, simulation.scene().material_names, (directory_ / "final_state.csv").string(),
                    final_state_bonds(simulation));
}

void EndOfRunFiles::finish(const Simulation& simulation) {
  if (!analysis_.figures()) throw std::logic_error("EndOfRunFiles: attach it after RunAnalysis");
  write_end_of_run_files(directory_, simulation.scene().particles,
                         simulation.scene().material_names, final_state_bonds(simulation),
                         *analysis_.figures(), [this] { checkpoint_.wait_written(); });
}

void write_end_of_run_files(const std::filesystem::path& directory, const Particles& p,
                            const std::vector<std::string>& material_names,
                            const std::vector<int>& bonds, const RunFigures& figures,
                            const std::function<void()>& before_commit) {
  OutputSet end_of_run(
      {directory / "final_state.csv", directory / "clusters.csv", directory / "layer.csv"});
  AtomicFile final_state((directory / "final_state.csv").string());
  put_final_state(final_state, p, material_names, bonds);
  if (before_commit) before_commit();
  final_state.commit();
  write_clusters(figures.clusters, (directory / "clusters.csv").string());
  if (figures.layer) write_layer(*figures.layer, (directory / "layer.csv").string());
  end_of_run.keep();
}

}  // namespace bondem
