#pragma once
/// @file checkpoint.hpp
/// Exact checkpoints: every bit of state a run needs to continue as if never stopped.

#include <cstdint>
#include <stdexcept>
#include <string>

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
inline constexpr std::uint32_t kCheckpointVersion = 3;

/// The complete state of a run at the end of a step.
struct Checkpoint {
  std::uint64_t case_fingerprint = 0;  ///< case_fingerprint() of the case that wrote it
  Particles particles;                 ///< current order, forces included
  StepperState stepper;                ///< time, step, neighbor-list build positions
  std::string history;                 ///< history.csv rows written so far
};

/// Hash of everything in a case that shapes the trajectory (materials, laws, time step, domain,
/// walls, neighbor settings, particle count) but not the end time or the outputs, so a
/// checkpoint can be continued to a later end time.
std::uint64_t case_fingerprint(const Case& description);

/// Write atomically (temporary file, then rename): magic, version, payload size, payload,
/// FNV-1a checksum. Throws std::runtime_error on I/O failure.
void write_checkpoint(const std::string& path, const Checkpoint& checkpoint);

/// Read and verify a checkpoint. Throws CheckpointError naming the file and the problem.
Checkpoint read_checkpoint(const std::string& path);

}  // namespace bondem
