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
    if (stepper_.closing_pending()) {
      // An observer that reads nothing threw: the observers hear of it at a settled state.
      try {
        stepper_.settle();
      } catch (const BlowUpError&) {  // the first error is the one reported
      }
    }
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
  // Steps whose end state no observer reads leave their closing half-kicks to the next step's
  // opening sweep (Stepper::defer_closing_kicks), which they take as their pass 2 ends
  // (Stepper::drift_ahead): the same bytes, one sweep fewer, and the forces read from the caches.
  // Every way out of the loop below sees a settled state, but a blow-up's.
  stepper_.defer_closing_kicks(true);
  struct Undefer {
    Stepper& stepper;
    ~Undefer() {
      stepper.defer_closing_kicks(false);
      stepper.drift_ahead(false);
    }
  } undefer{stepper_};
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
      // Drifted ahead, the state is the next step's: a stop request that came meanwhile waits
      // for that step, which reads it.
      if (!stepper_.drifted() && state_read(step())) stepper_.settle();
      for (Observer* observer : observers_) observer->after_step(*this);
    } catch (const BlowUpError& error) {
      end.loop_seconds = elapsed();
      return blown_up(error);
    }
    if (stop_flag_ != nullptr && *stop_flag_ != 0 && !at_end() && !stepper_.drifted()) {
      end.loop_seconds = elapsed();
      try {
        stepper_.settle();  // the flag may have risen after state_read()
      } catch (const BlowUpError& error) {
        return blown_up(error);
      }
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
