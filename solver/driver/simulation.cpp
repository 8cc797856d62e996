#include "solver/driver/simulation.hpp"

#include <chrono>

namespace bondem {

Simulation::Simulation(const Scene& scene, Stepper& stepper, std::int64_t last_step)
    : scene_(scene), stepper_(stepper), last_step_(last_step) {}

void Simulation::interrupt(const Interruption& why) const {
  for (Observer* observer : observers_) observer->interrupted(*this, why);
}

RunEnd Simulation::run() {
  using Clock = std::chrono::steady_clock;
  RunEnd end;
  end.first_step = step();
  // A blow-up is an ending like the others: every observer hears it, then run() returns. After a
  // drift ahead (Stepper::drifted) they hear of it at that drift, the forces those of the step.
  const auto blown_up = [&](const BlowUpError& error) {
    end.step = step();
    end.stopped = StopReason::kBlowUp;
    end.blow_up = error;
    interrupt({StopReason::kBlowUp, &*end.blow_up});
    return end;
  };
  try {
    for (Observer* observer : observers_) observer->start(*this);
  } catch (const BlowUpError& error) {
    return blown_up(error);
  }
  // The loop's time excludes the start hooks (the first frame, the first history row).
  const Clock::time_point started = Clock::now();
  const auto elapsed = [&] {
    return std::chrono::duration<double>(Clock::now() - started).count();
  };
  // Steps whose end state no observer reads give their closing half-kicks with the next step's
  // opening ones and drift, as their pass 2 ends (Stepper::drift_ahead): the same bytes, one
  // sweep fewer, and the forces read from the caches. Every way out of the loop below sees a
  // settled state, but a blow-up's.
  struct NoDriftAhead {
    Stepper& stepper;
    ~NoDriftAhead() { stepper.drift_ahead(false); }
  } no_drift_ahead{stepper_};
  const auto state_read = [&](std::int64_t at) {
    if (at == last_step_ || (stop_flag_ != nullptr && *stop_flag_ != 0)) return true;
    for (const Observer* observer : observers_) {
      if (observer->reads_state(*this, at)) return true;
    }
    return false;
  };
  while (step() < last_step_) {
    try {
      stepper_.drift_ahead(!state_read(step() + 1));
      stepper_.step();
      for (Observer* observer : observers_) observer->after_step(*this);
    } catch (const BlowUpError& error) {
      end.loop_seconds = elapsed();
      return blown_up(error);
    }
    // Drifted ahead, the state is the next step's: a stop request that came meanwhile waits for
    // that step, which state_read() then settles.
    if (stop_flag_ != nullptr && *stop_flag_ != 0 && !at_end() && !stepper_.drifted()) {
      end.loop_seconds = elapsed();
      end.step = step();
      end.stopped = StopReason::kStopRequested;
      interrupt({StopReason::kStopRequested, nullptr});
      return end;
    }
  }
  end.loop_seconds = elapsed();
  end.step = step();
  end.finished = true;
  // Every after_step() has run (the last VTK frame among them): the end of the run reads no
  // per-pair force, and its outputs and analysis get their memory.
  stepper_.release_pair_forces();
  for (Observer* observer : observers_) observer->finish(*this);
  return end;
}

}  // namespace bondem
