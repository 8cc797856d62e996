#pragma once
/// @file slip_record.hpp
/// The state one pair carries from step to step, keyed by particle ids: what checkpoints hold and
/// what a case that starts from another run's state (initial_state) takes over.

#include <cstdint>
#include <functional>

namespace bondem {

/// What a pair carries from step to step, keyed by ids: its tangential spring and EPSD rolling
/// spring (both seen from the first particle), whether it was bonded and whether a JKR contact
/// holds it.
struct SlipRecord {
  std::int64_t first_id, second_id;
  double sx, sy, sz;
  double rx = 0.0, ry = 0.0, rz = 0.0;
  std::uint8_t bonded = 0;
  std::uint8_t joined = 0;
};

/// Visits a set of pair records, one at a time (by value of a checkpoint read as it is visited:
/// the records are never all in memory).
using SlipSource = std::function<void(const std::function<void(const SlipRecord&)>&)>;

}  // namespace bondem
