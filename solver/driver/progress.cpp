#include "solver/driver/progress.hpp"

#include <unistd.h>

#include <cstdio>
#include <ostream>
#include <sstream>

namespace bondem {

Progress::Progress(std::ostream& log, bool quiet)
    : log_(log), quiet_(quiet), terminal_(::isatty(::fileno(stderr)) != 0) {}

void Progress::start(const Simulation& simulation) {
  first_ = simulation.step();
  last_ = simulation.last_step();
  particles_ = static_cast<double>(simulation.scene().particles.size());
  start_ = Clock::now();
  shown_ = start_;
}

void Progress::after_step(const Simulation& simulation) {
  const std::int64_t step = simulation.step();
  if (quiet_ || (step & 31) != 0) return;
  const auto now = Clock::now();
  if (now - shown_ < (terminal_ ? std::chrono::milliseconds(500) : std::chrono::seconds(10)))
    return;
  shown_ = now;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const double rate = static_cast<double>(step - first_) / elapsed;
  std::ostringstream line;
  line.precision(4);
  line << "t = " << simulation.stepper().time() << " s  "
       << 100.0 * static_cast<double>(step) / static_cast<double>(last_) << " %  " << rate
       << " steps/s  " << rate * particles_ << " particle-steps/s  "
       << static_cast<double>(last_ - step) / rate << " s left";
  if (terminal_) {
    log_ << '\r' << line.str() << "\x1b[K" << std::flush;
  } else {
    log_ << line.str() << '\n';
  }
}

void Progress::interrupted(const Simulation& /*simulation*/, const Interruption& /*why*/) {
  end_line();
}

void Progress::finish(const Simulation& /*simulation*/) {
  end_line();
}

void Progress::end_line() {
  if (!quiet_ && terminal_) log_ << '\n';
}

}  // namespace bondem
