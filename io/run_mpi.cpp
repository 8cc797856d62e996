#include "io/run_mpi.hpp"

#include <mpi.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <limits>
#include <memory>
#include <numeric>
#include <optional>
#include <ostream>
#include <span>
#include <sstream>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "io/case_file.hpp"
#include "io/checkpoint.hpp"
#include "io/mpi_world.hpp"
#include "io/run_observers.hpp"
#include "io/run_plan.hpp"
#include "io/vtk_output.hpp"
#include "solver/driver/history.hpp"
#include "solver/driver/progress.hpp"
#include "solver/driver/run_analysis.hpp"
#include "solver/driver/simulation.hpp"
#include "solver/engine/exact_sum.hpp"
#include "solver/engine/particle_stream.hpp"
#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"
#include "solver/parallel/decomposition.hpp"
#include "solver/parallel/particle_transfer.hpp"
#include "solver/parallel/rank_part.hpp"

namespace bondem {

namespace {

/// Under BONDEM_MPI_PROFILE, this process's resident and peak memory at @p where, on stderr.
void note_memory(const char* where) {
  if (std::getenv("BONDEM_MPI_PROFILE") == nullptr) return;
  std::ifstream status("/proc/self/status");
  std::string line, rss, peak;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) rss = line.substr(6);
    if (line.rfind("VmHWM:", 0) == 0) peak = line.substr(6);
  }
  std::cerr << "bondem: process " << world_rank() << " " << where << ": resident" << rss << ", peak"
            << peak << "\n";
}

/// The kinds of error that every process rethrows when one throws it.
enum class ErrorKind : int { kNone, kCase, kBlowUp, kInterrupted, kInvalidArgument, kOther };

/// Runs @p action on every process. When it throws on some, every process throws the error of
/// the lowest rank that failed: all leave the run together, with the same message and exit
/// status, and none waits forever for a partner that has left.
template <class Action>
void together(Action&& action) {
  ErrorKind kind = ErrorKind::kNone;
  int cause = 0;
  std::string message;
  try {
    action();
  } catch (const CaseError& e) {
    kind = ErrorKind::kCase;
    message = e.what();
  } catch (const BlowUpError& e) {
    kind = ErrorKind::kBlowUp;
    cause = static_cast<int>(e.cause());
    message = e.what();
  } catch (const RunInterrupted& e) {
    kind = ErrorKind::kInterrupted;
    message = e.what();
  } catch (const std::invalid_argument& e) {
    kind = ErrorKind::kInvalidArgument;
    message = e.what();
  } catch (const std::exception& e) {
    kind = ErrorKind::kOther;
    message = e.what();
  }
  const int size = world_size();
  const int mine = kind == ErrorKind::kNone ? size : world_rank();
  int first = size;
  MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  if (first == size) return;
  int header[3] = {static_cast<int>(kind), cause, static_cast<int>(message.size())};
  MPI_Bcast(header, 3, MPI_INT, first, MPI_COMM_WORLD);
  message.resize(static_cast<std::size_t>(header[2]));
  MPI_Bcast(message.data(), header[2], MPI_CHAR, first, MPI_COMM_WORLD);
  switch (static_cast<ErrorKind>(header[0])) {
    case ErrorKind::kCase:
      throw CaseError(message);
    case ErrorKind::kBlowUp:
      throw BlowUpError(message, static_cast<BlowUpCause>(header[1]));
    case ErrorKind::kInterrupted:
      throw RunInterrupted(message);
    case ErrorKind::kInvalidArgument:
      throw std::invalid_argument(message);
    default:
      throw std::runtime_error(message);
  }
}

/// The exact sums @p mine of every process added up, on every process: their digits are added
/// as integers, so the result is the bytes a single process summing every term gets.
std::vector<ExactSum> summed(const std::vector<ExactSum>& mine) {
  constexpr std::size_t kDigits = std::tuple_size_v<ExactSum::Digits>;
  std::vector<std::int64_t> digits(mine.size() * kDigits);
  std::vector<double> specials(mine.size());
  for (std::size_t k = 0; k < mine.size(); ++k) {
    const ExactSum::Digits d = mine[k].digits();
    std::copy(d.begin(), d.end(), digits.begin() + static_cast<std::ptrdiff_t>(k * kDigits));
    specials[k] = mine[k].special();
  }
  MPI_Allreduce(MPI_IN_PLACE, digits.data(), static_cast<int>(digits.size()), MPI_INT64_T, MPI_SUM,
                MPI_COMM_WORLD);
  MPI_Allreduce(MPI_IN_PLACE, specials.data(), static_cast<int>(specials.size()), MPI_DOUBLE,
                MPI_SUM, MPI_COMM_WORLD);
  std::vector<ExactSum> sums(mine.size());
  for (std::size_t k = 0; k < mine.size(); ++k) {
    ExactSum::Digits d;
    std::copy_n(digits.begin() + static_cast<std::ptrdiff_t>(k * kDigits), kDigits, d.begin());
    sums[k] = ExactSum::from_digits(d, specials[k]);
  }
  return sums;
}

/// The processes' shares of a force evaluation's summary put together: counts added, maxima
/// taken (each pair is counted by one process; a maximum over every process's pairs is exact).
ContactSummary summed(const ContactSummary& mine) {
  std::uint64_t counts[5] = {mine.contacts, mine.bonds, mine.wall_contacts, mine.bonds_formed,
                             mine.bonds_broken};
  double maxima[3] = {mine.max_overlap, mine.max_overlap_fraction, mine.thermal_step_ratio};
  MPI_Allreduce(MPI_IN_PLACE, counts, 5, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
  MPI_Allreduce(MPI_IN_PLACE, maxima, 3, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  ContactSummary total;
  total.contacts = counts[0];
  total.bonds = counts[1];
  total.wall_contacts = counts[2];
  total.bonds_formed = counts[3];
  total.bonds_broken = counts[4];
  total.max_overlap = maxima[0];
  total.max_overlap_fraction = maxima[1];
  total.thermal_step_ratio = maxima[2];
  return total;
}

/// How the processes agree on a laser deposit (deposit_laser_heat): the smallest radius in the
/// beam's window and each column's highest particle, equal tops going to the smaller id.
LaserAgreement laser_agreement() {
  LaserAgreement agreement;
  agreement.smallest_radius = [](double& r_min) {
    MPI_Allreduce(MPI_IN_PLACE, &r_min, 1, MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
  };
  agreement.highest_tops = [](std::vector<double>& top, std::vector<std::int64_t>& id) {
    const std::vector<double> mine = top;
    MPI_Allreduce(MPI_IN_PLACE, top.data(), static_cast<int>(top.size()), MPI_DOUBLE, MPI_MAX,
                  MPI_COMM_WORLD);
    // Of the processes whose top is the highest, the smallest id.
    for (std::size_t c = 0; c < top.size(); ++c) {
      if (mine[c] != top[c]) id[c] = std::numeric_limits<std::int64_t>::max();
    }
    MPI_Allreduce(MPI_IN_PLACE, id.data(), static_cast<int>(id.size()), MPI_INT64_T, MPI_MIN,
                  MPI_COMM_WORLD);
  };
  return agreement;
}

/// The phases of a distributed step, timed for BONDEM_MPI_PROFILE.
enum class Phase { kMove, kAgree, kGhosts, kForces, kWait, kTotals, kRedistribute, kCount };

/// Wall time per phase, from lap to lap.
class PhaseTimer {
 public:
  void start() { last_ = Clock::now(); }
  /// Adds the time since the last lap (or start()) to @p phase.
  void lap(Phase phase) {
    const Clock::time_point now = Clock::now();
    seconds_[static_cast<std::size_t>(phase)] += std::chrono::duration<double>(now - last_).count();
    last_ = now;
  }
  /// "move 1.2 s, agree 0.1 s, ...".
  std::string text() const {
    static constexpr const char* kNames[] = {"move",        "agree on rebuild",     "ghosts",
                                             "forces",      "wait for the slowest", "totals",
                                             "redistribute"};
    std::ostringstream out;
    out.precision(4);
    for (std::size_t k = 0; k < seconds_.size(); ++k) {
      out << (k == 0 ? "" : ", ") << kNames[k] << " " << seconds_[k] << " s";
    }
    return out.str();
  }

 private:
  using Clock = std::chrono::steady_clock;
  Clock::time_point last_;
  std::array<double, static_cast<std::size_t>(Phase::kCount)> seconds_{};
};

/// Wraps the positions of @p p into @p domain along its periodic axes, as a list build does:
/// before particles are handed to the owners of their positions.
void wrap_periodic_positions(Particles& p, const Domain& domain) {
  const Eigen::Vector3d length = domain.length();
  for (int a = 0; a < 3; ++a) {
    if (!domain.periodic[a]) continue;
    StaggeredVector<double>& coordinate = a == 0 ? p.x : (a == 1 ? p.y : p.z);
    for (double& c : coordinate) c = wrap_periodic(c, domain.min[a], length[a]);
  }
}

/// The runs of values a gather to rank 0 concatenated in rank order (@p bytes from each process,
/// @p size bytes a value): where each process's next value and its end are, in values.
struct GatheredRuns {
  GatheredRuns(const std::vector<std::int64_t>& bytes, std::size_t size)
      : next(bytes.size(), 0), end(bytes.size(), 0) {
    for (std::size_t r = 0; r < bytes.size(); ++r) {
      next[r] = r == 0 ? 0 : end[r - 1];
      end[r] = next[r] + static_cast<std::size_t>(bytes[r]) / size;
    }
  }
  std::vector<std::size_t> next, end;
};

/// A merge of GatheredRuns, each in order of @p key (key(index) of an entry): pop() gives the
/// process whose next entry has the least key (the lower process on a tie), in O(log R); the
/// caller takes that process's entries, advancing runs.next, then puts it back with push().
template <class Key>
class RunMerge {
 public:
  RunMerge(const GatheredRuns& runs, Key key) : runs_(runs), key_(std::move(key)) {
    for (std::size_t r = 0; r < runs.next.size(); ++r) push(r);
  }
  /// Whether some run has entries left.
  bool any() const { return !heap_.empty(); }
  /// The process with the least next key, out of the merge until push().
  std::size_t pop() {
    std::pop_heap(heap_.begin(), heap_.end(), std::greater<>());
    const std::size_t r = heap_.back().second;
    heap_.pop_back();
    return r;
  }
  /// Process @p r back into the merge, if its run has entries left.
  void push(std::size_t r) {
    if (runs_.next[r] >= runs_.end[r]) return;
    heap_.emplace_back(key_(runs_.next[r]), r);
    std::push_heap(heap_.begin(), heap_.end(), std::greater<>());
  }

 private:
  const GatheredRuns& runs_;
  Key key_;
  std::vector<std::pair<std::invoke_result_t<Key&, std::size_t>, std::size_t>> heap_;
};

/// Every process's owned particles in id order, cut into chunks of kChunk ids:
/// how the parts stream values to rank 0 by id (a checkpoint's columns and pairs, the end of a
/// run) without any process holding the whole run's at once. Collective to build and to use.
class IdStream {
 public:
  /// Ids per chunk: a chunk of the widest column (wall slips, 144 B a particle with 6 walls) is
  /// 2.4 MB, and the few held at once add little to the peak of a step.
  static constexpr std::size_t kChunk = std::size_t{1} << 14;

  /// Over the particles of @p p that @p part owns.
  IdStream(const Particles& p, const RankPart& part) {
    for (std::uint32_t k = 0; k < p.size(); ++k) {
      if (part.owns(p.id[k])) rows_.push_back(k);
    }
    std::sort(rows_.begin(), rows_.end(),
              [&](std::uint32_t a, std::uint32_t b) { return p.id[a] < p.id[b]; });
    // Chunks by id, kChunk ids each: ids are below the next free one, so few chunks are empty.
    std::int64_t largest = rows_.empty() ? -1 : p.id[rows_.back()];
    MPI_Allreduce(MPI_IN_PLACE, &largest, 1, MPI_INT64_T, MPI_MAX, MPI_COMM_WORLD);
    const auto chunk_ids = static_cast<std::int64_t>(kChunk);
    const std::int64_t chunks = largest / chunk_ids + 1;
    for (std::int64_t c = 0; c <= chunks; ++c) {  // rows_[cuts_[c], cuts_[c + 1]): chunk c's
      cuts_.push_back(static_cast<std::size_t>(
          std::lower_bound(rows_.begin(), rows_.end(), c * chunk_ids,
                           [&](std::uint32_t row, std::int64_t id) { return p.id[row] < id; }) -
          rows_.begin()));
    }
    // Rank 0 learns which process holds each particle of the run by id, merging the processes'
    // sorted ids a chunk at a time (a whole run's ids at once would be 8 B a particle more).
    const bool root = world_rank() == 0;
    total_ = rows_.size();
    MPI_Allreduce(MPI_IN_PLACE, &total_, 1, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
    if (root) source_.reserve(total_);
    for (std::size_t c = 0; c + 1 < cuts_.size(); ++c) {
      std::vector<std::int64_t> bytes;
      std::vector<std::int64_t> ids(cuts_[c + 1] - cuts_[c]);
      for (std::size_t k = 0; k < ids.size(); ++k) ids[k] = p.id[rows_[cuts_[c] + k]];
      const std::vector<std::int64_t> all = gathered(std::move(ids), true, &bytes);
      if (!root) continue;
      GatheredRuns runs(bytes, sizeof(std::int64_t));
      RunMerge merge(runs, [&](std::size_t at) { return all[at]; });
      while (merge.any()) {
        const std::size_t lowest = merge.pop();
        ++runs.next[lowest];
        source_.push_back(static_cast<std::int32_t>(lowest));
        merge.push(lowest);
      }
      chunk_begins_.push_back(source_.size() - all.size());
    }
  }

  /// Particles of the whole run.
  std::uint64_t total() const { return total_; }
  /// This process's owned particles by id, as indices of its part.
  const std::vector<std::uint32_t>& rows() const { return rows_; }

  /// On rank 0, @p emit receives @p column's values of every particle of the run by id, a chunk
  /// at a time; every process sends its own.
  void column(PartColumn column, const Emit& emit) const {
    std::vector<char> merged;
    for (std::size_t c = 0; c + 1 < cuts_.size(); ++c) {
      std::vector<char> mine;
      mine.reserve((cuts_[c + 1] - cuts_[c]) * column.bytes + kTransferUnit);
      for (std::size_t k = cuts_[c]; k < cuts_[c + 1]; ++k) {
        const char* value = column.data + rows_[k] * column.bytes;
        mine.insert(mine.end(), value, value + column.bytes);
      }
      std::vector<std::int64_t> bytes;
      const std::vector<char> all = gathered(std::move(mine), true, &bytes);
      if (world_rank() != 0) continue;
      GatheredRuns runs(bytes, 1);  // in bytes
      const std::size_t first = chunk_begins_[c];
      const std::size_t end = c + 1 < chunk_begins_.size() ? chunk_begins_[c + 1] : source_.size();
      merged.resize((end - first) * column.bytes);
      for (std::size_t k = first; k < end; ++k) {
        std::size_t& from = runs.next[static_cast<std::size_t>(source_[k])];
        std::memcpy(merged.data() + (k - first) * column.bytes, all.data() + from, column.bytes);
        from += column.bytes;
      }
      emit(merged.data(), merged.size());
    }
  }

  /// On rank 0, @p visit receives every pair with carried state by (first id, second id), from
  /// the process owning its first particle (@p stepper: this process's); a chunk at a time.
  template <class Visit>
  void slips(const Stepper& stepper, Visit&& visit) const {
    for (std::size_t c = 0; c + 1 < cuts_.size(); ++c) {
      std::vector<SlipRecord> mine;
      const std::span<const std::uint32_t> chunk(rows_.data() + cuts_[c], cuts_[c + 1] - cuts_[c]);
      std::size_t count = 0;
      stepper.for_each_slip(chunk, [&](const SlipRecord&) { ++count; });
      mine.reserve(count);
      stepper.for_each_slip(chunk, [&](const SlipRecord& s) { mine.push_back(s); });
      std::vector<std::int64_t> bytes;
      const std::vector<SlipRecord> all = gathered(std::move(mine), true, &bytes);
      if (world_rank() != 0) continue;
      // Each process's pairs are in order, and a first particle's pairs all come from its owner.
      GatheredRuns runs(bytes, sizeof(SlipRecord));
      RunMerge merge(runs, [&](std::size_t at) { return all[at].first_id; });
      while (merge.any()) {
        const std::size_t r = merge.pop();
        const std::int64_t first_id = all[runs.next[r]].first_id;
        while (runs.next[r] < runs.end[r] && all[runs.next[r]].first_id == first_id) {
          visit(static_cast<const SlipRecord&>(all[runs.next[r]++]));
        }
        merge.push(r);
      }
    }
  }

  /// Rank 0's copy of @p values (this process's part's, one a particle) for every particle of
  /// the run by id; empty elsewhere.
  template <class T, class Allocator>
  std::vector<T> by_id(const std::vector<T, Allocator>& values) const {
    std::vector<T> all;
    if (world_rank() == 0) all.reserve(total_);
    column({reinterpret_cast<const char*>(values.data()), sizeof(T)},
           [&](const char* data, std::size_t size) {
             const std::size_t at = all.size();
             all.resize(at + size / sizeof(T));
             std::memcpy(all.data() + at, data, size);
           });
    return all;
  }

 private:
  std::vector<std::uint32_t> rows_;
  std::vector<std::size_t> cuts_;
  std::vector<std::int32_t> source_;  ///< on rank 0: the process of each particle of the run, by id
  std::vector<std::size_t> chunk_begins_;  ///< on rank 0: where each chunk starts in source_
  std::uint64_t total_ = 0;
};

/// A contact of a VTK frame as it travels between processes (ContactRecord, flat).
struct ContactBytes {
  std::int64_t id_i, id_j;
  double first[3], second[3], force[3];
  double overlap, normal_force;
  std::uint8_t bonded;
};

/// The VTK frames of a distributed run. Process r writes piece r of each frame: the particles
/// whose id modulo the number of processes is r, and the contacts whose smaller id is one of
/// theirs. The pieces follow the ids, not the cuts, so a frame's files do not depend on where the
/// cuts fell: a restart on as many processes writes the uninterrupted run's bytes. Each process
/// derives what it counts (coordination, bond count, contacts) and sends it to the piece's writer.
class PieceFrames {
 public:
  /// Frames into @p directory every @p every steps with the particle arrays @p fields (empty:
  /// all); @p scene: the run's, with a particle of the run (the fields every record carries).
  PieceFrames(const std::filesystem::path& directory, std::int64_t every,
              std::vector<std::string> fields, const Scene& scene)
      : every_(every),
        writer_(directory.string()),
        one_particle_(particle_prototype(scene.particles)) {
    writer_.select_particle_arrays(std::move(fields));
    writer_.set_pieces(world_rank(), world_size());
    writer_.set_material_names(scene.material_names);
    writer_.set_bonds_series(some_pair_can_bond(scene));
  }

  /// As VtkFrames::resume: keep the frames an uninterrupted run writes up to @p checkpoint_step.
  /// Process 0 trims the series; every process learns which frames stay.
  void resume(const Scene& scene, std::int64_t checkpoint_step, double time_step) {
    writer_.resume(
        [&](double time) {
          const std::int64_t step = std::llround(time / time_step);
          return step <= checkpoint_step && step % every_ == 0;
        },
        scene.boundaries, scene.domain);
  }

  std::int64_t every() const { return every_; }

  /// Write a frame of @p scene stepped by @p stepper (a process's part, or on every process the
  /// whole run), from the particles @p counts (by id) and the contacts whose smaller id it counts;
  /// @p loads: the whole run's boundary loads. Every process calls it; the frame is listed once
  /// every piece is written.
  template <class Counts>
  void write(const Scene& scene, const Stepper& stepper, Counts&& counts,
             std::vector<BoundaryLoad> loads) {
    const auto processes = static_cast<std::size_t>(world_size());
    const Particles& p = scene.particles;
    std::vector<double> coordination, bond_count;
    std::vector<std::vector<ContactBytes>> contacts(processes);
    frame_contacts(scene, stepper, coordination, bond_count,
                   [&](std::size_t i, const ContactRecord& r) {
                     if (!counts(p.id[i])) return;  // the pair's smaller id leads it
                     ContactBytes c{};              // zeroed: its padding travels too
                     c.id_i = r.id_i;
                     c.id_j = r.id_j;
                     for (int a = 0; a < 3; ++a) {
                       c.first[a] = r.first_position[a];
                       c.second[a] = r.second_position[a];
                       c.force[a] = r.force[a];
                     }
                     c.overlap = r.overlap;
                     c.normal_force = r.normal_force;
                     c.bonded = r.bonded ? 1 : 0;
                     contacts[piece_of(r.id_i)].push_back(c);
                   });
    std::vector<std::vector<char>> records(processes);
    std::vector<std::vector<double>> derived(processes);  // coordination, bond count
    for (std::size_t i = 0; i < p.size(); ++i) {
      if (!counts(p.id[i])) continue;
      const std::size_t piece = piece_of(p.id[i]);
      pack_particle(p, i, records[piece]);
      derived[piece].insert(derived[piece].end(), {coordination[i], bond_count[i]});
    }

    std::vector<std::int64_t> received;
    const std::vector<char> arrived = bondem::exchanged(records, received);
    std::vector<std::vector<char>> out;
    for (const std::vector<double>& values : derived) out.push_back(bytes_of(values));
    const std::vector<double> arrived_derived = values_of<double>(bondem::exchanged(out, received));
    out.clear();
    for (const std::vector<ContactBytes>& some : contacts) out.push_back(bytes_of(some));
    std::vector<ContactBytes> arrived_contacts =
        values_of<ContactBytes>(bondem::exchanged(out, received));

    Particles piece = one_particle_;
    std::vector<char> one;
    pack_particle(one_particle_, 0, one);
    const std::size_t n = arrived.size() / one.size();
    piece.permute(std::vector<std::uint32_t>(n, 0));
    for (std::size_t k = 0; k < n; ++k) unpack_particle(arrived.data() + k * one.size(), piece, k);
    coordination_.resize(n);
    bond_count_.resize(n);
    diameter_.resize(n);
    for (std::size_t k = 0; k < n; ++k) {
      coordination_[k] = arrived_derived[2 * k];
      bond_count_[k] = arrived_derived[2 * k + 1];
      diameter_[k] = 2.0 * piece.radius[k];
    }
    std::sort(arrived_contacts.begin(), arrived_contacts.end(),
              [](const ContactBytes& a, const ContactBytes& b) {
                return std::pair(a.id_i, a.id_j) < std::pair(b.id_i, b.id_j);
              });
    std::vector<ContactRecord> records_of_piece;
    for (const ContactBytes& c : arrived_contacts) {
      records_of_piece.push_back({c.id_i, c.id_j, Eigen::Vector3d(c.first),
                                  Eigen::Vector3d(c.second), c.overlap, c.normal_force,
                                  c.bonded != 0, Eigen::Vector3d(c.force)});
    }
    std::vector<BoundaryLoadRecord> load_records;
    for (std::size_t b = 0; b < loads.size(); ++b) {
      load_records.push_back({scene.boundaries[b].name, loads[b].force, loads[b].moment});
    }
    writer_.set_boundary_loads(std::move(load_records));
    const std::vector<std::string>& names = VtkFrames::derived_arrays();
    together([&] {
      writer_.write_frame(
          stepper.time(), piece, records_of_piece, scene.boundaries, scene.domain,
          {{names[0], &coordination_}, {names[1], &bond_count_}, {names[2], &diameter_}});
    });
    together([&] { writer_.publish(); });  // every piece is written
  }

 private:
  std::size_t piece_of(std::int64_t id) const {
    return static_cast<std::size_t>(id % static_cast<std::int64_t>(world_size()));
  }

  std::int64_t every_;
  VtkSeriesWriter writer_;
  Particles one_particle_;
  std::vector<double> coordination_, bond_count_, diameter_;
};

/// A scene and a stepper holding the whole run's state: what rank 0 assembles from every
/// process's particles to write state snapshots and layer series with the observers of the run
/// in one process (checkpoints and the end of the run are streamed from the parts instead).
struct WholeRun {
  std::unique_ptr<Scene> scene;
  std::unique_ptr<Stepper> stepper;
};

/// bisect_spread()'s reductions across the processes of the run.
SpreadReductions across_processes() {
  return {[](std::span<double> values) {
            MPI_Allreduce(MPI_IN_PLACE, values.data(), static_cast<int>(values.size()), MPI_DOUBLE,
                          MPI_SUM, MPI_COMM_WORLD);
          },
          [](std::span<double> values) {
            MPI_Allreduce(MPI_IN_PLACE, values.data(), static_cast<int>(values.size()), MPI_DOUBLE,
                          MPI_MAX, MPI_COMM_WORLD);
          }};
}

/// The halo of a run of scene @p frame: decomposition_halo() of its largest radius, the case's
/// and its streams' (Scene::largest_radius), which no particle of the run exceeds.
double run_halo(const Scene& frame) {
  return 2.0 * frame.largest_radius + frame.contact_range + 2.0 * frame.skin;
}

/// The cuts of a restart, decided from every particle's position before each process reads only
/// the particles of its part, and their halo.
struct RestartCuts {
  Decomposition decomposition;
  double halo = 0.0;
};

/// This process's part of a distributed run: its RankPart, the ghost exchange with the other
/// processes, and the run's totals, which every process holds.
class DistributedRun {
 public:
  /// Continue a restart from @p part, the rows of the checkpoint this process read (its part
  /// under @p cuts, owned and halo), with @p state: this process's part is a copy of @p frame
  /// (the run's scene without its particles) with those particles.
  DistributedRun(Scene frame, Particles part, StepperState state, const RestartCuts& cuts)
      : frame_(std::move(frame)),
        thermal_(part.thermal()),
        contacts_(state.contacts),
        bonds_formed_(state.bonds_formed),
        bonds_broken_(state.bonds_broken),
        removed_(state.removed) {
    adopt_layout(part);
    distribute(std::move(part), std::move(state), cuts);
  }

  /// Start a fresh run from this process's own particles @p owned (those @p decomposition gives
  /// it, @p halo the width of the halos), each in @p frame (the run's scene without particles,
  /// with its initial pairs): the processes trade their halos, and each part evaluates its
  /// initial forces, counting its share; a stream's next particle takes @p next_particle_id.
  DistributedRun(Scene frame, Particles owned, const Decomposition& decomposition, double halo,
                 std::int64_t next_particle_id)
      : frame_(std::move(frame)),
        decomposition_(decomposition),
        halo_(halo),
        thermal_(owned.thermal()) {
    adopt_layout(owned);
    const std::size_t count = owned.size();
    take_part(std::move(owned), count, {}, std::nullopt, next_particle_id);
    frame_.initial_pairs = std::vector<SlipRecord>{};  // the parts' fresh steppers took them
    contacts_ = summed(part_.stepper->contacts());
    bonds_formed_ = part_.stepper->bonds_formed();
    MPI_Allreduce(MPI_IN_PLACE, &bonds_formed_, 1, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);
    load_sums_ = summed(part_.stepper->boundary_load_sums());
  }

  /// One step: the opening kicks and the drift; then either the ghosts' motion from their
  /// owners or, when some process needs a rebuild, the rebuild every process takes (particles
  /// that crossed a cut migrate, halos are sent anew and each process's new part builds its list:
  /// the one build of the step, as in one process); the forces and closing kicks; the totals.
  /// Returns whether some process was asked to stop (@p stop_here: this one was).
  bool step(bool stop_here) {
    timer_.start();
    double local[2] = {part_.stepper->move(), stop_here ? 1.0 : 0.0};
    timer_.lap(Phase::kMove);
    MPI_Allreduce(MPI_IN_PLACE, local, 2, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    timer_.lap(Phase::kAgree);
    const double half_skin = 0.5 * part_.scene->skin;
    // As in one process, an insertion rebuilds the list (a collective: every process agrees).
    const bool inserted = part_.stepper->streams_due() && insert_from_streams();
    if (local[0] > half_skin * half_skin || inserted) {
      wrap_periodic_positions(part_.scene->particles, part_.scene->domain);
      wrap_periodic_positions(arriving_, part_.scene->domain);
      mark_outside();
      rebuild_parts();
      arriving_ = Particles{};
      timer_.lap(Phase::kRedistribute);
    } else {
      refresh_ghosts();
      timer_.lap(Phase::kGhosts);
    }
    std::exception_ptr failure;  // a blow-up here ends every process's run, below
    try {
      part_.stepper->complete_step(false);  // a rebuild's list is the new part's
    } catch (...) {
      failure = std::current_exception();
    }
    timer_.lap(Phase::kForces);
    together([&] {
      if (failure) std::rethrow_exception(failure);
    });
    timer_.lap(Phase::kWait);
    // This process's share only: the processes add their shares up when a total is read
    // (sum_totals), at a history row, a frame or the end, not at every step.
    step_contacts_ = part_.stepper->contacts();
    step_loads_ = part_.stepper->boundary_load_sums();
    unsummed_formed_ += static_cast<std::int64_t>(step_contacts_.bonds_formed);
    unsummed_broken_ += static_cast<std::int64_t>(step_contacts_.bonds_broken);
    totals_pending_ = true;
    timer_.lap(Phase::kTotals);
    return local[1] != 0.0;
  }

  /// What this process's steps spent in each phase, in seconds, for BONDEM_MPI_PROFILE.
  std::string profile() const {
    return timer_.text() + " (rebuilds: " + std::to_string(migrations_) + " migrations, " +
           std::to_string(redistributions_) + " redistributions)";
  }

  /// The whole run's totals at this step (a history row), on every process.
  RunTotals totals() const {
    sum_totals();
    const Stepper& stepper = *part_.stepper;
    const Particles& p = part_.scene->particles;
    RunTotals t;
    t.time = stepper.time();
    const std::vector<ExactSum> energies = summed(
        std::vector<ExactSum>{stepper.kinetic_energy_sum(), stepper.rotational_energy_sum()});
    t.kinetic_energy = energies[0].value();
    t.rotational_energy = energies[1].value();
    t.contacts = contacts_;
    t.bonds_formed = bonds_formed_;
    t.bonds_broken = bonds_broken_;
    std::uint64_t owned = part_.owned_ids.size();
    MPI_Allreduce(MPI_IN_PLACE, &owned, 1, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
    t.particles = owned;
    if (thermal_) {
      ExactSum sum;
      double hottest = -std::numeric_limits<double>::infinity();
      for (std::size_t i = 0; i < p.size(); ++i) {
        if (!part_.owns(p.id[i])) continue;
        sum.add(p.temperature[i]);
        hottest = std::max(hottest, p.temperature[i]);
      }
      MPI_Allreduce(MPI_IN_PLACE, &hottest, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
      const double ambient = part_.scene->ambient_temperature;
      t.max_temperature = owned > 0 ? hottest : ambient;
      t.mean_temperature =
          owned > 0 ? summed(std::vector<ExactSum>{sum})[0].value() / static_cast<double>(owned)
                    : ambient;
      t.laser_energy = stepper.laser_energy();
    }
    for (const ParticleTally& stream : stepper.streams()) {  // the same on every process
      t.inserted += stream.count;
      t.inserted_mass += stream.mass;
    }
    t.removed = removed_.count;
    t.removed_mass = removed_.mass;
    t.loads = boundary_loads_of(load_sums_);
    return t;
  }

  /// On rank 0, the whole run's state assembled from every process's owned particles and pairs
  /// (each pair sent by the owner of its smaller id); elsewhere, nothing. Every process calls it.
  WholeRun assemble() {
    sum_totals();
    const bool root = world_rank() == 0;
    StepperState state = part_.stepper->save_state(SavedArrays::kOmitted);
    std::vector<std::uint32_t> owned;
    const Particles& p = part_.scene->particles;
    for (std::uint32_t k = 0; k < p.size(); ++k) {
      if (part_.owns(p.id[k])) owned.push_back(k);
    }
    std::vector<double> build_positions;  // x0, y0, z0 of each owned particle
    std::vector<SlipRecord> slips;        // of the pairs the owned particles lead
    const NeighborList& list = part_.stepper->neighbors();
    build_positions.reserve(3 * owned.size());
    std::size_t pairs = 0;  // counted first: a vector grown by doubling would peak at twice
    part_.stepper->for_each_slip(owned, [&](const SlipRecord&) { ++pairs; });
    slips.reserve(pairs);
    for (const std::uint32_t k : owned) {
      build_positions.insert(
          build_positions.end(),
          {list.build_positions(0)[k], list.build_positions(1)[k], list.build_positions(2)[k]});
    }
    part_.stepper->for_each_slip(owned, [&](const SlipRecord& s) { slips.push_back(s); });
    std::vector<char> records;
    records.reserve(owned.size() * record_bytes_ + kTransferUnit);  // padded in place
    for (const std::uint32_t k : owned) pack_particle(p, k, records);
    Particles all;
    if (const std::vector<char> all_records = gathered(std::move(records), true); root) {
      all = particles_from(all_records);
    }
    const std::vector<std::uint32_t> by_id = all.order_by_id();
    all.permute(by_id);
    StepperState whole = std::move(state);
    if (const std::vector<double> all_positions = gathered(std::move(build_positions), true);
        root) {
      for (int axis = 0; axis < 3; ++axis) {
        StaggeredVector<double> positions(by_id.size());
        for (std::size_t k = 0; k < by_id.size(); ++k) {
          positions[k] = all_positions[3 * by_id[k] + static_cast<std::size_t>(axis)];
        }
        (axis == 0 ? whole.list.x0 : axis == 1 ? whole.list.y0 : whole.list.z0).swap(positions);
      }
    }
    // In any order: the stepper keys the pairs' state by ids.
    whole.slips = gathered(std::move(slips), true);
    if (!root) return {};

    whole.contacts = contacts_;
    whole.bonds_formed = bonds_formed_;
    whole.bonds_broken = bonds_broken_;
    whole.removed = removed_;
    WholeRun run;
    run.scene = std::make_unique<Scene>(frame_);
    run.scene->particles = std::move(all);
    run.stepper = std::make_unique<Stepper>(*run.scene, std::move(whole));
    return run;
  }

  /// Write the whole run's checkpoint to @p path (rank 0) from every process's part, streamed by
  /// id: the same bytes as the run in one process writes, and no process holds the whole run's
  /// state. @p fingerprint and @p history as CheckpointFile's. Every process calls it.
  void write_checkpoint(const std::string& path, std::uint64_t fingerprint,
                        const std::string& history) const {
    const IdStream order(part_.scene->particles, part_);
    write_checkpoint(order, path, fingerprint, history);
  }

  /// The same, over @p order (an IdStream of this part).
  void write_checkpoint(const IdStream& order, const std::string& path, std::uint64_t fingerprint,
                        const std::string& history) const {
    sum_totals();
    const Stepper& stepper = *part_.stepper;
    StepperState state = stepper.save_state(SavedArrays::kOmitted);
    state.contacts = contacts_;
    state.bonds_formed = bonds_formed_;
    state.bonds_broken = bonds_broken_;
    state.removed = removed_;
    std::uint64_t slips = 0;
    stepper.for_each_slip(order.rows(), [&](const SlipRecord&) { ++slips; });
    MPI_Allreduce(MPI_IN_PLACE, &slips, 1, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
    DistributedParts parts;
    parts.particles = order.total();
    parts.slips = slips;
    parts.column = [&order](PartColumn column, const Emit& emit) { order.column(column, emit); };
    const NeighborList& list = stepper.neighbors();
    const CheckpointView view{
        fingerprint,
        part_.scene->particles,
        state,
        history,
        part_.scene->material_names,
        {&list.build_positions(0), &list.build_positions(1), &list.build_positions(2)},
        [&](const std::function<void(const SlipRecord&)>& visit) { order.slips(stepper, visit); },
        std::make_shared<const std::vector<std::uint32_t>>(),
        std::move(parts),
        std::nullopt};
    together([&] {
      if (world_rank() == 0) {
        bondem::write_checkpoint(path, view);
      } else {
        serve_checkpoint(view);
      }
    });
  }

  /// What rank 0 writes and measures at the end of a run (or at a stop), without a stepper.
  struct EndState {
    Particles particles;        ///< by id, with the fields of a final state and of the analysis
    std::vector<int> bonds;     ///< per particle, in thermal runs
    std::vector<int> contacts;  ///< per particle, the partners it overlaps (when analysed)
    std::vector<std::pair<std::uint32_t, std::uint32_t>> bonded;  ///< by index (when analysed)
    RunCounts counts;
    double laser_energy = 0.0, laser_missed = 0.0;
  };

  /// The EndState gathered on rank 0 (elsewhere only its counts) from every process's part,
  /// over @p order, which each process frees as it sends: its stepper once its counts are taken,
  /// each field once sent. A stop needs only the final state (@p analysed false). Every process
  /// calls it; the part is gone afterwards.
  EndState finish(const IdStream& order, bool analysed) {
    sum_totals();
    Particles& p = part_.scene->particles;
    const Stepper& stepper = *part_.stepper;
    const bool thermal = p.thermal();
    EndState end;
    end.counts.particles = order.total();
    end.counts.neighbor_builds = stepper.neighbors().build_count();
    end.counts.contacts = contacts_;
    end.counts.bonds_formed = bonds_formed_;
    end.counts.bonds_broken = bonds_broken_;
    end.laser_energy = stepper.laser_energy();
    end.laser_missed = stepper.laser_missed();
    // An owned particle's partners all lie in the part (the halo), so its counts are the run's.
    std::vector<int> bonds = thermal ? bond_counts(p, stepper) : std::vector<int>{};
    std::vector<int> contacts =
        analysed ? contact_counts(p, stepper.neighbors()) : std::vector<int>{};
    std::vector<std::int64_t> bonded_ids;  // each pair from the owner of its smaller id
    if (analysed) {
      for (const auto& [i, j] : bonded_pairs(stepper)) {
        if (!part_.owns(std::min(p.id[i], p.id[j]))) continue;
        bonded_ids.insert(bonded_ids.end(), {p.id[i], p.id[j]});
      }
    }
    part_.stepper.reset();
    const bool root = world_rank() == 0;
    Particles& all = end.particles;
    all = state_by_id(p, order, true);
    if (thermal) end.bonds = order.by_id(bonds);
    if (analysed) end.contacts = order.by_id(contacts);
    std::vector<int>().swap(bonds);
    std::vector<int>().swap(contacts);
    part_.scene.reset();
    const std::vector<std::int64_t> pairs = gathered(std::move(bonded_ids), true);
    if (root) {
      const auto index_of = [&](std::int64_t id) {
        return static_cast<std::uint32_t>(std::lower_bound(all.id.begin(), all.id.end(), id) -
                                          all.id.begin());
      };
      for (std::size_t k = 0; k + 1 < pairs.size(); k += 2) {
        end.bonded.emplace_back(index_of(pairs[k]), index_of(pairs[k + 1]));
      }
    }
    return end;
  }

  /// On rank 0, the fields of a final state (and in thermal runs each particle's bond count,
  /// @p bonds) of every particle of the run, by id, streamed from the parts: what a state
  /// snapshot writes, without assembling the whole run. Every process calls it.
  Particles snapshot(std::vector<int>& bonds) {
    const Particles& p = part_.scene->particles;
    const IdStream order(p, part_);
    Particles all = state_by_id(p, order, false);
    if (thermal_) bonds = order.by_id(bond_counts(p, *part_.stepper));
    return all;
  }

  const RankPart& part() const { return part_; }
  /// The whole run's boundary loads at this step, on every process.
  std::vector<BoundaryLoad> loads() const {
    sum_totals();
    return boundary_loads_of(load_sums_);
  }
  /// Rebuilds so far that moved the cuts (redistributions) or kept them (migrations).
  std::int64_t redistributions() const { return redistributions_; }
  std::int64_t migrations() const { return migrations_; }

 private:
  /// Adds the processes' shares of the steps since the last call into the run's totals (a
  /// collective: every process calls it at the same point, as it calls what reads them). One
  /// sum when a total is read instead of four collectives at every step.
  void sum_totals() const {
    if (!totals_pending_) return;
    contacts_ = summed(step_contacts_);
    std::int64_t bonds[2] = {unsummed_formed_, unsummed_broken_};
    MPI_Allreduce(MPI_IN_PLACE, bonds, 2, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);
    bonds_formed_ += bonds[0];
    bonds_broken_ += bonds[1];
    unsummed_formed_ = unsummed_broken_ = 0;
    load_sums_ = summed(step_loads_);
    totals_pending_ = false;
  }

  /// On rank 0, the fields of a final state of every particle of the run by id, from each
  /// process's @p p over @p order (empty elsewhere); with @p free_sent (the end of the run) each
  /// of @p p's fields is freed as soon as it is sent.
  template <class Part>
  Particles state_by_id(Part& p, const IdStream& order, bool free_sent) const {
    Particles all;
    all.temperatures_tracked = thermal_;
    for (const ParticleField& field : kParticleFields) {
      const bool listed = has(field, kLastGood) ||
                          (thermal_ && (std::string_view(field.name) == "temperature" ||
                                        std::string_view(field.name) == "peak_temperature"));
      if (!listed) continue;
      std::visit(
          [&](auto member) {
            auto& values = p.*member;
            std::vector<typename std::decay_t<decltype(values)>::value_type> every =
                order.by_id(values);
            (all.*member).assign(every.begin(), every.end());
            if constexpr (!std::is_const_v<Part>) {
              if (free_sent) std::decay_t<decltype(values)>().swap(values);
            }
          },
          field.member);
    }
    return all;
  }

  /// @p records (packed particles of this run) as particles, in their order.
  Particles particles_from(const std::vector<char>& records) const {
    const std::size_t n = records.size() / record_bytes_;
    Particles all = one_particle_;
    all.permute(std::vector<std::uint32_t>(n, 0));
    for (std::size_t k = 0; k < n; ++k) unpack_particle(records.data() + k * record_bytes_, all, k);
    return all;
  }

  /// Take this process's part of @p all under @p cuts, continuing @p state; then list what to
  /// send to each process after every step and where its particles go.
  void distribute(Particles all, StepperState state, const RestartCuts& cuts) {
    const int size = world_size();
    const int rank = world_rank();
    const Scene& probe = frame_;
    const double halo = cuts.halo;
    const Decomposition& d = cuts.decomposition;
    decomposition_ = d;
    halo_ = halo;
    // Each process sends the owned particles in another's halo, by id; the other receives them
    // into its ghosts of the same ids, in the same order. The ids are listed before the part
    // takes @p all.
    std::vector<int> owner(all.size());
    for (std::size_t i = 0; i < all.size(); ++i) owner[i] = d.owner(all.x[i], all.y[i], all.z[i]);
    std::vector<std::vector<std::int64_t>> sent_ids(static_cast<std::size_t>(size));
    std::vector<std::vector<std::int64_t>> received_ids(static_cast<std::size_t>(size));
    const std::vector<std::uint32_t> mine =
        subdomain_members(d, rank, probe.domain, halo, all.x, all.y, all.z);
    for (int r = 0; r < size; ++r) {
      if (r == rank) continue;
      std::vector<std::int64_t>& sent = sent_ids[static_cast<std::size_t>(r)];
      for (const std::uint32_t i :
           subdomain_members(d, r, probe.domain, halo, all.x, all.y, all.z)) {
        if (owner[i] == rank) sent.push_back(all.id[i]);
      }
      std::vector<std::int64_t>& received = received_ids[static_cast<std::size_t>(r)];
      for (const std::uint32_t i : mine) {
        if (owner[i] == r) received.push_back(all.id[i]);
      }
    }
    std::vector<int>().swap(owner);
    part_.stepper.reset();  // before the scene it steps
    part_ = make_rank_part(frame_, d, rank, halo, std::move(all), std::move(state));
    adopt(*part_.stepper);

    // Where each particle of the part sits, by id.
    const Particles& p = part_.scene->particles;
    std::vector<std::pair<std::int64_t, std::uint32_t>> index_of(p.size());
    for (std::size_t k = 0; k < p.size(); ++k)
      index_of[k] = {p.id[k], static_cast<std::uint32_t>(k)};
    std::sort(index_of.begin(), index_of.end());
    const auto local_indices = [&](std::vector<std::int64_t>& ids) {
      std::sort(ids.begin(), ids.end());
      std::vector<std::uint32_t> indices(ids.size());
      for (std::size_t k = 0; k < ids.size(); ++k) {
        indices[k] =
            std::lower_bound(index_of.begin(), index_of.end(), std::pair(ids[k], std::uint32_t{0}))
                ->second;
      }
      return indices;
    };
    sends_.assign(static_cast<std::size_t>(size), {});
    receives_.assign(static_cast<std::size_t>(size), {});
    for (int r = 0; r < size; ++r) {
      if (r == rank) continue;
      sends_[static_cast<std::size_t>(r)] = local_indices(sent_ids[static_cast<std::size_t>(r)]);
      receives_[static_cast<std::size_t>(r)] =
          local_indices(received_ids[static_cast<std::size_t>(r)]);
    }
  }

  /// The particles the streams owe at this step, inserted alike on every process into the
  /// particles near the streams' regions gathered from every process (the only ones an insertion
  /// tests against): arriving_, which the rebuild this forces hands to their owners. Returns
  /// whether any was inserted. Every process calls it.
  bool insert_from_streams() {
    const Scene& scene = *part_.scene;
    const Particles& p = scene.particles;
    std::vector<std::uint8_t> near(p.size(), 0);
    for (const ParticleStream& stream : scene.streams) {
      for (const std::uint32_t k :
           particles_near_stream(stream, scene.largest_radius, scene.domain, p)) {
        near[k] = 1;
      }
    }
    std::vector<double> mine;  // x, y, z, radius of each owned particle near a stream
    for (std::size_t k = 0; k < p.size(); ++k) {
      if (near[k] != 0 && part_.owns(p.id[k])) {
        mine.insert(mine.end(), {p.x[k], p.y[k], p.z[k], p.radius[k]});
      }
    }
    const std::vector<double> every = gathered(std::move(mine));
    Particles around = one_particle_.selected({});
    const double at_rest[3] = {0.0, 0.0, 0.0};
    for (std::size_t k = 0; k + 3 < every.size(); k += 4) {
      around.add(-1, 0, every[k + 3], 0.0, &every[k], at_rest);  // only place and size count
    }
    const std::size_t present = around.size();
    if (part_.stepper->insert_due_into(around) == 0) return false;
    std::vector<std::uint32_t> added(around.size() - present);
    std::iota(added.begin(), added.end(), static_cast<std::uint32_t>(present));
    arriving_ = around.selected(added);
    return true;
  }

  /// The fields of @p like's particles: what every particle record of the run carries.
  void adopt_layout(const Particles& like) {
    one_particle_ = particle_prototype(like);
    std::vector<char> one;
    pack_particle(one_particle_, 0, one);
    record_bytes_ = one.size();
  }

  /// What a part's stepper leaves to the processes together: the laser's columns, insertion.
  void adopt(Stepper& stepper) const {
    if (frame_.laser) stepper.share_laser(laser_agreement());
    stepper.insert_elsewhere();
  }

  /// With Domain::remove_outside, at a rebuild: marks the particles outside the domain, which
  /// the new parts leave out (a ghost's owner drops it too), and counts the owned ones into the
  /// run's removed particles and mass. The mass removed at a rebuild is one exact sum over every
  /// process's particles, rounded once, as the run in one process adds it.
  void mark_outside() {
    const Particles& p = part_.scene->particles;
    const Domain& domain = part_.scene->domain;
    outside_.assign(p.size(), 0);
    arriving_outside_.assign(arriving_.size(), 0);
    if (!domain.remove_outside) return;
    ExactSum mass;
    std::int64_t count = 0;
    for (std::size_t k = 0; k < p.size(); ++k) {
      if (!domain.outside({p.x[k], p.y[k], p.z[k]})) continue;
      outside_[k] = 1;
      if (!part_.owns(p.id[k])) continue;
      ++count;
      mass.add(p.mass[k]);
    }
    for (std::size_t k = 0; k < arriving_.size(); ++k) {  // every process holds them: 0 counts
      if (!domain.outside({arriving_.x[k], arriving_.y[k], arriving_.z[k]})) continue;
      arriving_outside_[k] = 1;
      if (world_rank() != 0) continue;
      ++count;
      mass.add(arriving_.mass[k]);
    }
    MPI_Allreduce(MPI_IN_PLACE, &count, 1, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);
    const double removed_mass = summed(std::vector<ExactSum>{mass})[0].value();
    if (count == 0) return;
    removed_.count += count;
    removed_.mass += removed_mass;
  }

  /// Every ghost takes its owner's motion after the drift: position, velocity, spin and, in a
  /// thermal run, temperature, the state of a particle that pair forces read besides what a
  /// step does not change (radius, mass, material, id). Each process sends the others only the
  /// owned particles in their halos. The ghosts' other fields (forces, wall contacts) are this
  /// process's own evaluation, which nothing of an owned particle reads.
  void refresh_ghosts() {
    const int size = world_size();
    Particles& p = part_.scene->particles;
    std::vector<StaggeredVector<double>*> fields{&p.x,  &p.y,  &p.z,  &p.vx, &p.vy,
                                                 &p.vz, &p.wx, &p.wy, &p.wz};
    if (thermal_) fields.push_back(&p.temperature);
    const std::size_t width = fields.size();
    std::vector<int> send_counts(static_cast<std::size_t>(size)), send_offsets(send_counts.size());
    std::vector<int> receive_counts(send_counts.size()), receive_offsets(send_counts.size());
    send_values_.clear();
    receive_values_.clear();
    for (int r = 0; r < size; ++r) {
      const auto ur = static_cast<std::size_t>(r);
      send_offsets[ur] = static_cast<int>(send_values_.size());
      for (const std::uint32_t k : sends_[ur]) {
        for (const StaggeredVector<double>* field : fields) send_values_.push_back((*field)[k]);
      }
      send_counts[ur] = static_cast<int>(send_values_.size()) - send_offsets[ur];
      receive_offsets[ur] = static_cast<int>(receive_values_.size());
      receive_counts[ur] = static_cast<int>(receives_[ur].size() * width);
      receive_values_.resize(receive_values_.size() + receives_[ur].size() * width);
    }
    MPI_Alltoallv(send_values_.data(), send_counts.data(), send_offsets.data(), MPI_DOUBLE,
                  receive_values_.data(), receive_counts.data(), receive_offsets.data(), MPI_DOUBLE,
                  MPI_COMM_WORLD);
    const double* at = receive_values_.data();
    for (const std::vector<std::uint32_t>& ghosts : receives_) {
      for (const std::uint32_t k : ghosts) {
        for (StaggeredVector<double>* field : fields) (*field)[k] = *at++;
      }
    }
  }

  /// exchanged() of the pairs' state @p slips[r] for each process r.
  static std::vector<SlipRecord> exchanged(const std::vector<std::vector<SlipRecord>>& slips) {
    std::vector<std::vector<char>> out;
    for (const std::vector<SlipRecord>& some : slips) out.push_back(bytes_of(some));
    std::vector<std::int64_t> counts;
    return values_of<SlipRecord>(bondem::exchanged(out, counts));
  }

  /// At a rebuild: the particles go to the owners of their new positions with the state of the
  /// pairs they lead, then each process sends the others its particles in their halos, whole,
  /// with the pairs those lead. The cuts stay (a migration: only the particles that crossed one
  /// travel) while the most loaded process is within kRebalanceAbove of the mean, by
  /// stepping_costs(); otherwise they move first (a redistribution).
  void rebuild_parts() {
    const Particles& p = part_.scene->particles;
    const std::vector<double> costs = stepping_costs(*part_.stepper);  // of the last list
    double load[2] = {0.0, 0.0};  // the most loaded process's, and the total
    for (std::size_t k = 0; k < p.size(); ++k) {
      if (part_.owns(p.id[k])) load[0] += costs[k];
    }
    load[1] = load[0];
    MPI_Allreduce(MPI_IN_PLACE, &load[0], 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    MPI_Allreduce(MPI_IN_PLACE, &load[1], 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    if (load[0] > (1.0 + kRebalanceAbove) * load[1] / world_size()) {
      ++redistributions_;
      decomposition_ = balanced_cuts(costs);
    } else {
      ++migrations_;
    }
    move_to_owners();
  }

  /// Each owned particle (and each of a stream's that arrive) to the owner of its position under
  /// decomposition_, with the state of the pairs it leads; then the new halos (take_part).
  void move_to_owners() {
    const int rank = world_rank();
    const auto processes = static_cast<std::size_t>(world_size());
    const Particles& p = part_.scene->particles;
    Particles next;
    std::vector<SlipRecord> arrived_slips;  // of the pairs the arriving particles lead
    Stepper::CarriedPairs kept_pairs;       // of the pairs the kept particles lead
    StepperState state;
    {
      std::vector<int> new_owner(p.size(), -1);
      std::vector<std::uint32_t> kept;
      std::vector<std::vector<char>> leaving(processes);
      for (std::size_t k = 0; k < p.size(); ++k) {
        if (!part_.owns(p.id[k]) || outside_[k] != 0) continue;  // outside: removed
        new_owner[k] = decomposition_.owner(p.x[k], p.y[k], p.z[k]);
        if (new_owner[k] == rank) {
          kept.push_back(static_cast<std::uint32_t>(k));
        } else {
          pack_particle(p, k, leaving[static_cast<std::size_t>(new_owner[k])]);
        }
      }
      // The pairs the leaving particles lead travel as records; the kept ones' stay in the old
      // stepper's arrays, taken out by ids (72-B records of every kept pair would double what a
      // migration holds: 1.5 M pairs with a spring a process at 10^6).
      std::vector<std::vector<SlipRecord>> leaving_slips(processes);
      std::vector<std::uint8_t> kept_row(p.size(), 0);
      for (std::uint32_t k = 0; k < p.size(); ++k) {
        if (new_owner[k] < 0) continue;  // a ghost's pairs: its owner sends them
        if (new_owner[k] == rank) {
          kept_row[k] = 1;
          continue;
        }
        part_.stepper->for_each_slip(std::span(&k, 1), [&](const SlipRecord& slip) {
          leaving_slips[static_cast<std::size_t>(new_owner[k])].push_back(slip);
        });
      }
      arrived_slips = exchanged(leaving_slips);
      leaving_slips = {};
      // The old part's list and pairs are read: freed before anything else is built.
      state = part_.stepper->save_state(SavedArrays::kOmitted);
      kept_pairs = part_.stepper->take_pairs(kept_row);
      part_.stepper.reset();
      std::vector<std::int64_t> counts;
      const std::vector<char> arrived = bondem::exchanged(leaving, counts);
      next = std::move(part_.scene->particles);  // the kept ones, in place
      part_.scene.reset();
      next.permute(kept);
      const Particles newcomers = particles_from(arrived);
      for (std::size_t k = 0; k < newcomers.size(); ++k) append_particle(newcomers, k, next);
      for (std::size_t k = 0; k < arriving_.size(); ++k) {  // a stream's, every process holds them
        if (arriving_outside_[k] == 0 &&
            decomposition_.owner(arriving_.x[k], arriving_.y[k], arriving_.z[k]) == rank) {
          append_particle(arriving_, k, next);
        }
      }
    }  // what travelled is freed here
    const std::size_t owned = next.size();
    ++state.list.builds;  // the step's
    state.removed = removed_;
    take_part(std::move(next), owned, std::move(arrived_slips), std::move(state), 0,
              std::move(kept_pairs));
  }

  /// With the first @p owned particles of @p next this process's own from now on: sends every
  /// other process its particles in their halos, whole, with the state of the pairs of
  /// @p owned_slips and @p kept_pairs they lead; appends theirs as ghosts; and steps the new
  /// part, restored from @p state (a rebuild: its list built at these positions, the pairs'
  /// state by ids) or, without one, fresh (the initial pairs of the frame, the initial forces), a
  /// stream's next particle then taking @p next_particle_id.
  void take_part(Particles next, std::size_t owned, std::vector<SlipRecord> owned_slips,
                 std::optional<StepperState> state, std::int64_t next_particle_id = 0,
                 Stepper::CarriedPairs kept_pairs = {}) {
    const int size = world_size();
    const int rank = world_rank();
    const auto processes = static_cast<std::size_t>(size);
    std::vector<SlipRecord> ghost_slips_arrived;
    {  // Each process's particles in another's halo, whole, with the pairs they lead.
      std::vector<std::int64_t> counts;
      std::vector<std::vector<std::uint32_t>> ghost_sends(processes);
      std::vector<std::vector<char>> ghost_records(processes);
      std::vector<std::vector<SlipRecord>> ghost_slips(processes);
      for (int r = 0; r < size; ++r) {
        if (r == rank) continue;
        const auto ur = static_cast<std::size_t>(r);
        ghost_sends[ur] =
            subdomain_members(decomposition_, r, frame_.domain, halo_, next.x, next.y, next.z);
        // The ids sent, sorted: a halo's few, where the pairs' leaders are looked up.
        std::vector<std::int64_t> sent;
        for (const std::uint32_t k : ghost_sends[ur]) {
          pack_particle(next, k, ghost_records[ur]);
          sent.push_back(next.id[k]);
        }
        std::sort(sent.begin(), sent.end());
        const auto leader_sent = [&](std::int64_t first_id) {
          return std::binary_search(sent.begin(), sent.end(), first_id);
        };
        for (const SlipRecord& slip : owned_slips) {
          if (leader_sent(slip.first_id)) ghost_slips[ur].push_back(slip);
        }
        for (std::size_t n = 0; n < kept_pairs.keys.size(); ++n) {
          if (leader_sent(kept_pairs.keys[n].first_id)) {
            ghost_slips[ur].push_back(kept_pairs.record(n));
          }
        }
      }
      const std::vector<char> ghosts_arrived = bondem::exchanged(ghost_records, counts);
      ghost_slips_arrived = exchanged(ghost_slips);
      const Particles ghosts = particles_from(ghosts_arrived);
      for (std::size_t k = 0; k < ghosts.size(); ++k) append_particle(ghosts, k, next);
      // The ghost refresh: the same particles, in the same order, from the same owners.
      sends_ = std::move(ghost_sends);
      receives_.assign(processes, {});
      auto at = static_cast<std::uint32_t>(owned);
      for (std::size_t r = 0; r < processes; ++r) {
        const std::size_t records = static_cast<std::size_t>(counts[r]) / record_bytes_;
        for (std::size_t n = 0; n < records; ++n) receives_[r].push_back(at++);
      }
    }  // what travelled is freed before the new part's list is built

    // The new part.
    if (state) {
      state->list.x0 = next.x;
      state->list.y0 = next.y;
      state->list.z0 = next.z;
      // In any order: the stepper keys them by ids (each pair once: its leader's owner sent it).
      state->slips = std::move(owned_slips);
      state->slips.insert(state->slips.end(), ghost_slips_arrived.begin(),
                          ghost_slips_arrived.end());
    }
    RankPart fresh;
    fresh.scene = std::make_unique<Scene>(frame_);
    fresh.scene->particles = std::move(next);
    const auto& ids = fresh.scene->particles.id;
    fresh.owned_ids.assign(ids.begin(), ids.begin() + static_cast<std::ptrdiff_t>(owned));
    std::sort(fresh.owned_ids.begin(), fresh.owned_ids.end());
    if (state) {
      fresh.stepper =
          std::make_unique<Stepper>(*fresh.scene, std::move(*state), std::move(kept_pairs));
      fresh.stepper->count_only(fresh.owned_ids);
    } else {
      // A fresh list build may reorder the particles (Scene::reorder_interval): the refresh
      // follows them by id.
      const auto ids_of = [&](const std::vector<std::vector<std::uint32_t>>& rows) {
        std::vector<std::vector<std::int64_t>> by_process(rows.size());
        for (std::size_t r = 0; r < rows.size(); ++r) {
          for (const std::uint32_t k : rows[r]) {
            by_process[r].push_back(fresh.scene->particles.id[k]);
          }
        }
        return by_process;
      };
      const std::vector<std::vector<std::int64_t>> send_ids = ids_of(sends_);
      const std::vector<std::vector<std::int64_t>> receive_ids = ids_of(receives_);
      fresh.stepper =
          std::make_unique<Stepper>(*fresh.scene, RunShare{fresh.owned_ids, next_particle_id});
      const Particles& p = fresh.scene->particles;
      std::vector<std::pair<std::int64_t, std::uint32_t>> index_of(p.size());
      for (std::size_t k = 0; k < p.size(); ++k) {
        index_of[k] = {p.id[k], static_cast<std::uint32_t>(k)};
      }
      std::sort(index_of.begin(), index_of.end());
      const auto rows_of = [&](const std::vector<std::vector<std::int64_t>>& by_process,
                               std::vector<std::vector<std::uint32_t>>& rows) {
        for (std::size_t r = 0; r < by_process.size(); ++r) {
          for (std::size_t n = 0; n < by_process[r].size(); ++n) {
            rows[r][n] = std::lower_bound(index_of.begin(), index_of.end(),
                                          std::pair(by_process[r][n], std::uint32_t{0}))
                             ->second;
          }
        }
      };
      rows_of(send_ids, sends_);
      rows_of(receive_ids, receives_);
    }
    adopt(*fresh.stepper);
    part_.stepper.reset();  // before the scene it steps
    part_ = std::move(fresh);
  }

  /// New cuts of the owned particles' positions, weighted by their @p costs (stepping_costs(); a
  /// stream's arriving particles weigh 1), found from sums across the processes without any
  /// holding more than its own (bisect_spread()).
  Decomposition balanced_cuts(const std::vector<double>& costs) const {
    const Particles& p = part_.scene->particles;
    std::vector<double> x, y, z, cost;
    const auto add = [&](const Particles& from, std::size_t k, double weight) {
      x.push_back(from.x[k]);
      y.push_back(from.y[k]);
      z.push_back(from.z[k]);
      cost.push_back(weight);
    };
    for (std::size_t k = 0; k < p.size(); ++k) {
      if (part_.owns(p.id[k]) && outside_[k] == 0) add(p, k, costs[k]);  // outside: removed
    }
    if (world_rank() == 0) {  // a stream's new particles, which every process holds
      for (std::size_t k = 0; k < arriving_.size(); ++k) {
        if (arriving_outside_[k] == 0) add(arriving_, k, 1.0);
      }
    }
    return bisect_spread(x, y, z, cost, Box{frame_.domain.min, frame_.domain.max}, world_size(),
                         halo_, across_processes());
  }

  /// The load above the mean (by stepping_costs()) at which a rebuild moves the cuts.
  static constexpr double kRebalanceAbove = 0.05;

  Scene frame_;                  ///< the run's scene without particles: what each part copies
  Decomposition decomposition_;  ///< the cuts of the last redistribution
  double halo_ = 0.0;
  bool thermal_;  ///< the run's (a process may hold no particle to tell)
  RankPart part_;
  Particles one_particle_;  ///< a particle of the run: the fields every record carries
  std::size_t record_bytes_ = 0;
  std::vector<std::vector<std::uint32_t>> sends_;     ///< per process, owned particles it needs
  std::vector<std::vector<std::uint32_t>> receives_;  ///< per process, ghosts it owns
  std::vector<double> send_values_, receive_values_;
  // The run's totals, all processes together, as of the last sum_totals(): the contacts of the
  // last force evaluation, the boundary loads, the bonds formed and broken so far.
  mutable ContactSummary contacts_;
  mutable std::vector<ExactSum> load_sums_;
  mutable std::int64_t bonds_formed_ = 0, bonds_broken_ = 0;
  // This process's share of the last step's totals and its bonds since the last sum_totals().
  ContactSummary step_contacts_;
  std::vector<ExactSum> step_loads_;
  mutable std::int64_t unsummed_formed_ = 0, unsummed_broken_ = 0;
  mutable bool totals_pending_ = false;  ///< a step since the last sum_totals() (every process)
  ParticleTally removed_;                ///< for leaving the domain, all processes together
  std::vector<std::uint8_t> outside_;    ///< per particle of the part, at a rebuild: removed
  Particles arriving_;  ///< a stream's particles of this step, on every process, until the rebuild
  std::vector<std::uint8_t> arriving_outside_;  ///< per particle of arriving_: removed
  std::int64_t redistributions_ = 0;
  std::int64_t migrations_ = 0;
  PhaseTimer timer_;
};

/// A fresh run's start with no process holding the whole scene or every position: the cuts come
/// from each process's slice of the case's particles (bisect_spread(), each weighing 1: no list
/// has measured their cost yet, and the first rebuild moves the cuts if the measured cost is off
/// balance); each process then walks the list for the particles it owns (a lattice block
/// computes them, none is kept) and builds their scene; the parts then trade halos and evaluate
/// their initial forces.
std::optional<DistributedRun> start_fresh(Case& description) {
  Scene frame = build_scene(description, {});  // the values derived from every particle
  const ParticleList& specs = description.particles;
  const std::size_t n = specs.size();
  const double halo = run_halo(frame);
  const Domain& domain = frame.domain;
  const Eigen::Vector3d length = domain.length();
  const auto wrapped = [&](Eigen::Vector3d x) {  // as a list build wraps it
    for (int a = 0; a < 3; ++a) {
      if (domain.periodic[a]) x[a] = wrap_periodic(x[a], domain.min[a], length[a]);
    }
    return x;
  };
  Decomposition decomposition;
  {
    const auto size = static_cast<std::size_t>(world_size());
    const auto rank = static_cast<std::size_t>(world_rank());
    const std::size_t first = n * rank / size;
    const std::size_t count = n * (rank + 1) / size - first;
    std::vector<double> x(count), y(count), z(count);  // this process's slice of the list
    for (std::size_t k = 0; k < count; ++k) {
      const Eigen::Vector3d at = wrapped(specs[first + k].position);
      x[k] = at.x();
      y[k] = at.y();
      z[k] = at.z();
    }
    const std::vector<double> weights(count, 1.0);
    decomposition = bisect_spread(x, y, z, weights, Box{domain.min, domain.max}, world_size(), halo,
                                  across_processes());
  }
  std::vector<std::uint32_t> mine;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d x = wrapped(specs[i].position);
    if (decomposition.owner(x.x(), x.y(), x.z()) == world_rank()) {
      mine.push_back(static_cast<std::uint32_t>(i));
    }
  }
  // The id after the largest, as Stepper(scene) finds it in the whole scene.
  const std::int64_t next_id = next_particle_id(description);
  Scene own = build_scene(description, mine);
  description.particles.clear();
  Particles owned = std::move(own.particles);
  wrap_periodic_positions(owned, domain);
  own.particles = owned.selected({});  // the frame keeps the layout, no particle
  std::optional<DistributedRun> run;
  run.emplace(std::move(own), std::move(owned), decomposition, halo, next_id);
  return run;
}

}  // namespace

RunResult run_case_distributed(Case description, const RunOptions& options, std::ostream& log) {
  const bool root = world_rank() == 0;
  RunPlan plan;
  std::optional<Scene> scene;
  StepperState state;
  RunTotals first_totals;  // of step 0 (a fresh run's first history row)
  std::optional<RestartCuts> restart_cuts;
  std::string history_text;
  const bool vtk = description.vtk_interval > 0.0;
  // A restart's stages: each process reads the checkpoint's head and a slice of the rows'
  // positions (alone: an error ends every process together); the cuts, found across the
  // processes (collective: outside together(), where one process's error would leave the others
  // waiting), and the rows each part needs; then each process reads its part.
  std::size_t case_particles = 0;  // the case's own (a restart's checkpoint holds the particles)
  std::uint64_t file_particles = 0;
  Particles slice;  // a restart's: ids, positions and radii of this process's slice of rows
  const auto size = static_cast<std::uint64_t>(world_size());
  const auto rank = static_cast<std::uint64_t>(world_rank());
  together([&] {
    plan = plan_run(description, options);
    if (!plan.restarting) {
      scene.emplace(build_scene(description, {}));  // no particle: each process builds its own
      check_output_fields(description, *scene, history_text);
      return;
    }
    // The checkpoint holds the particles: the case's only count, and set the layout.
    case_particles = description.particles.size();
    scene.emplace(build_scene(description, {}));
    description.particles.clear();
    std::vector<SlipRecord>().swap(description.initial_pairs);
    try {
      const Checkpoint head =
          read_checkpoint(options.restart_path, CheckpointScope{.head_only = true});
      // Before the bisection: a checkpoint of another case is refused as such.
      check_checkpoint_fingerprint(head.case_fingerprint, description, options, plan);
      file_particles = head.file_particles;
      std::vector<std::uint64_t> mine(file_particles * (rank + 1) / size -
                                      file_particles * rank / size);
      std::iota(mine.begin(), mine.end(), file_particles * rank / size);
      slice = std::move(read_checkpoint(options.restart_path,
                                        CheckpointScope{.rows = &mine, .positions_only = true})
                            .particles);
    } catch (const CheckpointError& e) {
      throw CaseError(e.what());
    }
  });
  if (plan.restarting) {
    // No process reads every particle: the cuts come from all slices (bisect_spread(), each
    // particle weighing 1, as no list has measured the cost yet); each process tells every
    // other which rows of its slice lie in that one's part (owned or halo); each then reads
    // those rows, and its stepper the pairs (streamed from the file).
    const double halo = run_halo(*scene);
    const std::vector<double> weights(slice.size(), 1.0);
    const Decomposition cuts =
        bisect_spread(slice.x, slice.y, slice.z, weights, Box{scene->domain.min, scene->domain.max},
                      world_size(), halo, across_processes());
    restart_cuts.emplace(RestartCuts{cuts, halo});
    std::vector<std::vector<char>> wanted(static_cast<std::size_t>(size));
    std::vector<int> owner(slice.size());
    for (std::size_t k = 0; k < slice.size(); ++k) {
      owner[k] = cuts.owner(slice.x[k], slice.y[k], slice.z[k]);
    }
    std::vector<std::uint8_t> in_part(slice.size());
    const std::uint64_t first_row = file_particles * rank / size;
    for (std::size_t r = 0; r < wanted.size(); ++r) {
      for (std::size_t k = 0; k < slice.size(); ++k) {
        in_part[k] = owner[k] == static_cast<int>(r) ? 1 : 0;
      }
      for (const std::uint32_t k : subdomain_members(cuts, static_cast<int>(r), scene->domain, halo,
                                                     slice.x, slice.y, slice.z)) {
        in_part[k] = 1;
      }
      std::vector<std::uint64_t> theirs;
      for (std::size_t k = 0; k < slice.size(); ++k) {
        if (in_part[k] != 0) theirs.push_back(first_row + k);
      }
      wanted[r] = bytes_of(theirs);
    }
    slice = Particles{};
    std::vector<std::int64_t> received;
    std::vector<std::uint64_t> rows = values_of<std::uint64_t>(bondem::exchanged(wanted, received));
    std::sort(rows.begin(), rows.end());
    together([&] {
      Checkpoint restored =
          read_fitting_checkpoint(description, options, plan, *scene, case_particles, &rows);
      plan.first_step = restored.stepper.step;
      scene->particles = std::move(restored.particles);
      // As in run_case: displacements from here when the interrupted run did not track them.
      if (vtk && !scene->particles.displacement_tracked) scene->particles.track_displacement();
      history_text = history_without_end_row(restored.history, restored.stepper.step,
                                             restored.stepper.time, plan.history_every);
      state = std::move(restored.stepper);
      check_output_fields(description, *scene, history_text);
    });
  }
  note_memory("scene built");
  StaleOutputRemoval stale;  // an earlier run's outputs, unlinked while this one goes on
  together([&] {
    if (root) stale = prepare_output_directory(description, options, plan);
  });
  std::optional<PieceFrames> frames;  // first: a restart trims the series before the history
  if (vtk) {
    together([&] {
      frames.emplace(plan.directory, plan.vtk_every, description.vtk_fields, *scene);
      if (plan.restarting) frames->resume(*scene, state.step, description.time_step);
    });
  }
  std::optional<DistributedRun> run_part;
  if (plan.restarting) {
    Particles part = std::move(scene->particles);
    scene->particles = part.selected({});
    scene->initial_pairs = std::vector<SlipRecord>{};
    run_part.emplace(std::move(*scene), std::move(part), std::move(state), *restart_cuts);
  } else {
    // No process holds the whole scene: each builds its own particles, and the parts evaluate
    // the initial forces (each owned particle's are the run in one process's).
    scene.reset();
    together([&] { run_part = start_fresh(description); });
  }  // each process now holds its part only
  note_memory("distributed");
  DistributedRun& run = *run_part;
  scene.reset();
  state = StepperState{};
  const auto owns = [&](std::int64_t id) { return run.part().owns(id); };
  // Kept for the end of the run, when the parts are gone.
  const std::vector<std::string> names = run.part().scene->material_names;
  const Domain domain = run.part().scene->domain;
  if (!plan.restarting) {
    first_totals = run.totals();
    if (frames) frames->write(*run.part().scene, *run.part().stepper, owns, run.loads());
  }

  // Rank 0 writes the history, the checkpoints and the end-of-run files.
  std::optional<HistoryFile> history_file;
  if (root) history_file.emplace((plan.directory / "history.csv").string());
  History history(
      *run.part().scene, plan.history_every,
      [&](const std::string& text) {
        if (history_file) history_file->append(text);
      },
      description.history_fields);
  if (plan.restarting) history.continue_from(std::move(history_text));
  Progress progress(log, options.quiet || !root);
  // Each process keeps its own particles' state at every history row; on a blow-up rank 0
  // writes them all, by id, as the run in one process does.
  const std::string last_good_path = (plan.directory / "last_good_state.csv").string();
  std::optional<LastGoodFile> last_good;
  const auto keep_last_good = [&] {
    const Particles& p = run.part().scene->particles;
    std::vector<std::uint32_t> owned;
    for (std::uint32_t k = 0; k < p.size(); ++k) {
      if (run.part().owns(p.id[k])) owned.push_back(k);
    }
    last_good->keep(p, &owned);
  };
  together([&] {
    last_good.emplace(last_good_path, Particles{}, history, "_" + std::to_string(world_rank()));
    keep_last_good();
  });
  together([&] {
    if (history_file) history_file->append(history.text());  // the header, or a restart's rows
  });
  {
    Simulation rank_view(*run.part().scene, *run.part().stepper, plan.steps);
    progress.start(rank_view);
    progress.count_particles(run.totals().particles);
  }
  const auto add_row = [&](std::int64_t step, const RunTotals& totals) {
    together([&] {
      if (const std::string non_finite = history.add_row(step, totals); !non_finite.empty()) {
        std::ostringstream message;
        message << "step " << step << " (t = " << totals.time << " s): history value "
                << non_finite;
        throw BlowUpError(message.str(), BlowUpCause::kHistory);
      }
    });
  };
  // Layers are measured by rank 0 in the whole run assembled at their steps.
  std::optional<LayerFiles> layers;
  std::size_t layers_measured = 0;  // on every process: when to assemble for the next layer
  if (description.layers) {
    const std::int64_t resumed_at = plan.restarting ? plan.first_step : 0;
    layers_measured = layers_through(*description.layers, description.time_step, resumed_at);
    together([&] {
      if (!root) return;
      layers.emplace(plan.directory, *description.layers, description.time_step);
      if (plan.restarting) layers->resume(resumed_at);
    });
  }
  const auto at_whole_run = [&](auto&& use) {
    WholeRun whole = run.assemble();
    together([&] {
      if (!root) return;
      Simulation simulation(*whole.scene, *whole.stepper, plan.steps);
      use(simulation);
    });
  };

  // A state snapshot is the final state's fields by id, streamed from the parts to rank 0.
  const auto write_state = [&](std::int64_t step) {
    std::vector<int> bonds;
    const Particles snapshot = run.snapshot(bonds);
    together([&] {
      if (!root) return;
      write_final_state(snapshot, names,
                        (plan.directory / state_file_name(step / plan.state_every)).string(),
                        bonds);
    });
  };
  if (!plan.restarting && plan.state_every > 0) write_state(0);

  const auto started = std::chrono::steady_clock::now();
  try {
    if (!plan.restarting) add_row(0, first_totals);
    for (std::int64_t step = plan.first_step; step < plan.steps;) {
      const bool stop_here = options.stop_requested != nullptr && *options.stop_requested != 0;
      const bool stop = run.step(stop_here);
      ++step;
      if (step == plan.first_step + 1) note_memory("first step");
      const bool at_end = step == plan.steps;
      if (step % plan.history_every == 0 || at_end) {
        add_row(step, run.totals());
        // After the last step no step can blow up: that state is never needed.
        if (!at_end) together(keep_last_good);
      }
      if (frames && (step % frames->every() == 0 || at_end)) {
        frames->write(*run.part().scene, *run.part().stepper, owns, run.loads());
      }
      const bool state_due = plan.state_every > 0 && step % plan.state_every == 0;
      const std::size_t layers_due =
          description.layers ? layers_through(*description.layers, description.time_step, step) : 0;
      const bool layer_due = layers_due > layers_measured;
      const bool checkpoint_due = step % plan.checkpoint_every == 0 && !at_end;
      if (state_due) write_state(step);
      if (layer_due) {
        at_whole_run([&](const Simulation& s) { layers->after_step(s); });
        layers_measured = layers_due;
      }
      if (checkpoint_due)
        run.write_checkpoint(plan.checkpoint_path, plan.fingerprint, history.text());
      if (root) {
        Simulation rank_view(*run.part().scene, *run.part().stepper, plan.steps);
        progress.after_step(rank_view);
      }
      if (stop && !at_end) {
        // As VtkFrames: a frame of the state reached, off the grid (a restart drops it).
        if (frames && step % frames->every() != 0) {
          frames->write(*run.part().scene, *run.part().stepper, owns, run.loads());
        }
        // As the observers of a run in one process: the checkpoint, the final state, the
        // progress line; streamed from the parts.
        const double stopped_at = run.part().stepper->time();  // the part is freed below
        {
          const Interruption why{StopReason::kStopRequested, nullptr};
          const IdStream order(run.part().scene->particles, run.part());
          run.write_checkpoint(order, plan.checkpoint_path, plan.fingerprint, history.text());
          if (root)
            progress.interrupted(Simulation(*run.part().scene, *run.part().stepper, plan.steps),
                                 why);
          const DistributedRun::EndState end = run.finish(order, false);
          together([&] {
            if (root) {
              write_final_state(end.particles, names, (plan.directory / "final_state.csv").string(),
                                end.bonds);
            }
          });
        }
        std::ostringstream message;
        message << "interrupted at step " << step << " (t = " << stopped_at
                << " s); checkpoint written. Resume with: "
                << resume_command(options, description, plan.directory, plan.checkpoint_path);
        throw RunInterrupted(message.str());
      }
    }
  } catch (const BlowUpError& e) {
    // Every process is here (errors travel together): the state of the last history row, from
    // every process to rank 0, field by field in rank order, then written by id.
    Particles mine = last_good->kept();
    Particles all;
    for (const ParticleField& field : kParticleFields) {
      if (!has(field, kLastGood)) continue;
      std::visit(
          [&](auto member) {
            auto& values = mine.*member;
            using Value = typename std::decay_t<decltype(values)>::value_type;
            const std::vector<Value> every =
                gathered(std::vector<Value>(values.begin(), values.end()), true);
            (all.*member).assign(every.begin(), every.end());
            std::decay_t<decltype(values)>().swap(values);  // freed as soon as sent
          },
          field.member);
    }
    together([&] {
      if (root) write_final_state(all, run.part().scene->material_names, last_good_path);
    });
    throw BlowUpError(blow_up_message(e, description, plan), e.cause());
  }
  const double loop_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  if (std::getenv("BONDEM_MPI_PROFILE") != nullptr) {
    // One line a process, in rank order: where its steps went.
    const std::string line = "bondem: process " + std::to_string(world_rank()) + ": " +
                             run.profile() + ", " + std::to_string(run.part().owned_ids.size()) +
                             " owned of " + std::to_string(run.part().scene->particles.size()) +
                             " held\n";
    const std::vector<char> lines = gathered(std::vector<char>(line.begin(), line.end()), true);
    if (root) log << std::string(lines.begin(), lines.end()) << std::flush;
  }

  RunResult result;
  note_memory("steps done");
  const std::size_t owned_particles = run.part().owned_ids.size();
  // As the observers of a run in one process: the progress line, the checkpoint, the analysis and
  // the end-of-run files; streamed from the parts, which are freed as they are read.
  if (root) progress.finish(Simulation(*run.part().scene, *run.part().stepper, plan.steps));
  const IdStream order(run.part().scene->particles, run.part());
  run.write_checkpoint(order, plan.checkpoint_path, plan.fingerprint, history.text());
  note_memory("checkpoint written");
  {
    const DistributedRun::EndState end = run.finish(order, true);
    note_memory("end state gathered");
    together([&] {
      if (!root) return;
      const RunFigures figures =
          analyse_run(description, AnalysedState{end.particles, domain, end.contacts, end.bonded,
                                                 end.laser_energy, end.laser_missed});
      write_end_of_run_files(plan.directory, end.particles, names, end.bonds, figures);
      RunEnd run_end;
      run_end.finished = true;
      run_end.first_step = plan.first_step;
      run_end.step = plan.steps;
      run_end.loop_seconds = loop_seconds;
      result = collect_result(run_end, end.counts, figures);
    });
  }
  note_memory("end files written");
  if (!root) {
    result.steps = plan.steps - plan.first_step;
    result.particles = owned_particles;
    result.wall_seconds = loop_seconds;
  }
  return result;
}

}  // namespace bondem
