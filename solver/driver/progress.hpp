#pragma once
/// @file progress.hpp
/// Progress lines of a run: time, share done, rate and time left.

#include <chrono>
#include <cstdint>
#include <iosfwd>

#include "solver/driver/simulation.hpp"

namespace bondem {

/// Progress to @p log: on a terminal (stderr is one) one line rewritten in place every half
/// second, otherwise a plain line every ten seconds; nothing when quiet. Checks the clock every
/// 32 steps only.
class Progress : public Observer {
 public:
  Progress(std::ostream& log, bool quiet);

  void start(const Simulation& simulation) override;
  /// Rates in particle-steps of @p particles from now on (start() takes the scene's count): a
  /// decomposed run's process holds a part of the particles.
  void count_particles(std::size_t particles) { particles_ = static_cast<double>(particles); }
  void after_step(const Simulation& simulation) override;
  /// Never: it reads the step and the time only.
  bool reads_state(const Simulation& /*simulation*/, std::int64_t /*step*/) const override {
    return false;
  }
  /// Ends the line rewritten in place, so that what follows starts on its own line.
  void interrupted(const Simulation& simulation, const Interruption& why) override;
  void finish(const Simulation& simulation) override;

 private:
  using Clock = std::chrono::steady_clock;
  void end_line();

  std::ostream& log_;
  bool quiet_;
  bool terminal_;
  std::int64_t first_ = 0, last_ = 0;
  double particles_ = 0.0;
  Clock::time_point start_, shown_;
};

}  // namespace bondem
