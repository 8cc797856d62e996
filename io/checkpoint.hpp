#pragma once
/// @file checkpoint.hpp
/// Exact checkpoints: every bit of state a run needs to continue as if never stopped.

#include <array>
#include <cstdint>
#include <functional>
#include <iterator>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "solver/engine/particles.hpp"
#include "solver/engine/stepper.hpp"
#include "solver/setup/case.hpp"

namespace bondem {

/// A checkpoint that cannot be used: unreadable, truncated, corrupt, another version or case.
class CheckpointError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Format version written into every checkpoint; readers refuse any other.
inline constexpr std::uint32_t kCheckpointVersion = 10;

/// Where a checkpointed particle field sits in the file: per-particle arrays right after the
/// particle count, per-wall arrays after the wall count, thermal arrays after the thermal flag,
/// contact-history arrays after their flag, displacements after theirs, mesh contact normals after
/// theirs.
enum class CheckpointSection {
  kParticle,
  kWall,
  kThermal,
  kContactHistory,
  kDisplacement,
  kMeshHistory
};

/// The section of @p field.
constexpr CheckpointSection checkpoint_section(const ParticleField& field) {
  if (has(field, kThermal)) return CheckpointSection::kThermal;
  if (has(field, kContactHistory)) return CheckpointSection::kContactHistory;
  if (has(field, kDisplacementField)) return CheckpointSection::kDisplacement;
  if (has(field, kMeshHistory)) return CheckpointSection::kMeshHistory;
  return has(field, kPerWall) ? CheckpointSection::kWall : CheckpointSection::kParticle;
}

/// The particle fields of a version-7 checkpoint in file order. Not a list the code reads: a
/// guard. Checkpointing another field (or dropping or moving one) in kParticleFields fails to
/// compile until this list and kCheckpointVersion change with it, so that older checkpoints are
/// refused by their version instead of misread.
inline constexpr std::string_view kCheckpointParticleLayout[] = {"id",
                                                                 "material",
                                                                 "x",
                                                                 "y",
                                                                 "z",
                                                                 "vx",
                                                                 "vy",
                                                                 "vz",
                                                                 "fx",
                                                                 "fy",
                                                                 "fz",
                                                                 "radius",
                                                                 "mass",
                                                                 "wx",
                                                                 "wy",
                                                                 "wz",
                                                                 "tx",
                                                                 "ty",
                                                                 "tz",
                                                                 "wall_slip",
                                                                 "temperature",
                                                                 "peak_temperature",
                                                                 "inv_heat_capacity",
                                                                 "heat_rate",
                                                                 "wall_contact",
                                                                 "dx",
                                                                 "dy",
                                                                 "dz",
                                                                 "wall_normal"};

/// Whether the checkpointed rows of kParticleFields, in file order, are kCheckpointParticleLayout.
constexpr bool checkpoint_layout_unchanged() {
  std::size_t k = 0;
  for (const CheckpointSection section :
       {CheckpointSection::kParticle, CheckpointSection::kWall, CheckpointSection::kThermal,
        CheckpointSection::kContactHistory, CheckpointSection::kDisplacement,
        CheckpointSection::kMeshHistory}) {
    for (const ParticleField& field : kParticleFields) {
      if (!has(field, kCheckpointed) || checkpoint_section(field) != section) continue;
      if (k == std::size(kCheckpointParticleLayout) || kCheckpointParticleLayout[k] != field.name) {
        return false;
      }
      ++k;
    }
  }
  return k == std::size(kCheckpointParticleLayout);
}
static_assert(checkpoint_layout_unchanged(),
              "the checkpointed particle fields changed: bump kCheckpointVersion and update "
              "kCheckpointParticleLayout");

/// The complete state of a run at the end of a step.
struct Checkpoint {
  std::uint64_t case_fingerprint = 0;  ///< case_fingerprint() of the case that wrote it
  Particles particles;                 ///< current order, forces included
  StepperState stepper;                ///< time, step, neighbor-list build positions
  std::string history;                 ///< history.csv rows written so far
  /// Names of the materials, by the index the particles hold: how a case that starts from the
  /// checkpoint (initial_state) finds them among its own.
  std::vector<std::string> material_names;
  /// Particles the file holds: particles.size() unless only some rows were read.
  std::uint64_t file_particles = 0;
};

/// The canonical text of @p description that its fingerprint hashes, one `key=value` a line:
/// the resolved case (every field of Case, defaults included, and every particle exactly), then
/// every value the case-file reader read (Case::settings). Left out is only what a restart may
/// change: the end time and the output settings.
std::string canonical_case_text(const Case& description);

/// FNV-1a hash of canonical_case_text(), except that the particles' lines are hashed by their
/// values' bytes, per block of 4096 particles (in parallel), the block hashes folded in order:
/// equal for a case and its continuation to a later end time or with other outputs, different
/// when anything that shapes the trajectory differs.
std::uint64_t case_fingerprint(const Case& description);

/// Write atomically (temporary file, then rename): magic, version, payload size, payload,
/// checksum (FNV-1a by 64-bit words). The particles are written by id and the pairs by their
/// ids, so the file does not depend on the order the run stores them in. Throws
/// std::runtime_error on I/O failure.
void write_checkpoint(const std::string& path, const Checkpoint& checkpoint);

/// Calls its argument once with every pair's carried state, in the same order at every call.
using SlipVisitor = std::function<void(const std::function<void(const SlipRecord&)>&)>;

/// One process's values of a checkpointed column (a particle field, or an axis of the list's
/// build positions): @p bytes a particle, in the storage order of its part.
struct PartColumn {
  const char* data = nullptr;
  std::size_t bytes = 0;
};

/// Takes the next @p size bytes of a payload.
using Emit = std::function<void(const char* data, std::size_t size)>;

/// The parts of a distributed run, given on every process: the checkpoint's particles are then
/// this process's part (their layout: walls, fields in use; and its values); the counts are the
/// whole run's; the streams are collective: every process calls them alike, and the writer (rank
/// 0) receives every process's values, merged by id.
struct DistributedParts {
  std::uint64_t particles = 0;  ///< in the whole run
  std::uint64_t slips = 0;      ///< pairs with carried state in the whole run
  /// Emits @p column's values of every particle of the run by id (nothing away from the writer).
  std::function<void(PartColumn column, const Emit& emit)> column;
};

/// A checkpoint's content by reference: what a running simulation writes, without copying its
/// particles, its neighbor list's build positions or its pairs' state.
struct CheckpointView {
  std::uint64_t case_fingerprint = 0;
  const Particles& particles;
  /// Time, counts and boundaries; its list positions and slips are not read: see below.
  const StepperState& stepper;
  const std::string& history;
  const std::vector<std::string>& material_names;  ///< by material index
  /// The neighbor list's build positions, x, y and z.
  std::array<const StaggeredVector<double>*, 3> build_positions;
  /// The pairs' carried state (a write visits it once, twice without slips), by (first id,
  /// second id).
  SlipVisitor for_each_slip;
  /// The particles' order_by_id(): the checkpoint holds them by id, whatever their storage order.
  std::shared_ptr<const std::vector<std::uint32_t>> by_id;
  /// Set in a distributed run: the particles and the pairs come from every process's part, and
  /// for_each_slip is collective.
  std::optional<DistributedParts> parts;
  /// The number of pairs for_each_slip visits, where known without visiting them (a writer
  /// then walks the pairs once, not twice).
  std::optional<std::uint64_t> slips;
};

/// The view of @p checkpoint.
CheckpointView checkpoint_view(const Checkpoint& checkpoint);

/// The view of a running @p stepper's state: @p particles and @p history by reference, @p state
/// from Stepper::save_state(SavedArrays::kOmitted), the list positions and the pairs' state
/// streamed from @p stepper itself.
CheckpointView checkpoint_view(std::uint64_t case_fingerprint, const Particles& particles,
                               const Stepper& stepper, const StepperState& state,
                               const std::string& history,
                               const std::vector<std::string>& material_names);

/// Write @p checkpoint as write_checkpoint(path, Checkpoint) would, streamed: the payload is
/// serialized twice (counted, then written and hashed) and never held in memory, so a checkpoint
/// of 10^6 particles costs no copy of them.
void write_checkpoint(const std::string& path, const CheckpointView& checkpoint);

/// A distributed run's write_checkpoint() on the processes other than the writer: the same
/// collective streams of @p checkpoint.parts, contributing this process's values.
void serve_checkpoint(const CheckpointView& checkpoint);

/// Read and verify a checkpoint. Throws CheckpointError naming the file and the problem.
Checkpoint read_checkpoint(const std::string& path);

/// What read_checkpoint() reads of a checkpoint.
struct CheckpointScope {
  /// When set, only the particles of these rows (ascending; the file holds them by id), with
  /// their list positions, and the pairs with a kept particle: a distributed restart's part.
  const std::vector<std::uint64_t>* rows = nullptr;
  /// Only the ids, positions and radii of the particles: what a distributed restart bisects.
  bool positions_only = false;
  /// The pairs are not read into stepper.slips: stepper.slip_source visits them all from the file,
  /// kept open, as a restoring Stepper takes them, so that they need no memory of their own.
  bool pairs_streamed = false;
  /// Only the payload's head, unverified: the fingerprint, time, step, contact counts, list
  /// builds and file_particles (no particle): what a distributed restart divides the rows by.
  bool head_only = false;
};

/// Read and verify the part of a checkpoint that @p scope asks for.
Checkpoint read_checkpoint(const std::string& path, const CheckpointScope& scope);

/// The same, keeping only the particles of @p rows (ascending; the file holds them by id), with
/// their list positions, and the pairs with a kept particle: a distributed restart's part.
Checkpoint read_checkpoint(const std::string& path, const std::vector<std::uint64_t>& rows);

/// The ids, positions and radii of a checkpoint's particles, by id (no other field): what a
/// distributed restart bisects before it reads its part.
Particles read_checkpoint_positions(const std::string& path);

}  // namespace bondem
