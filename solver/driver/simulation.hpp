#pragma once
/// @file simulation.hpp
/// The time loop of a run: a scene, its stepper and the observers that watch it step.

#include <csignal>
#include <cstdint>
#include <optional>
#include <vector>

#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"

namespace bondem {

class Simulation;

/// Why a run ended before its last step.
enum class StopReason {
  kStopRequested,  ///< the stop flag was raised (SIGINT, SIGTERM): the state is sound
  kBlowUp,         ///< the stepper or an observer threw BlowUpError: the state is not
};

/// What interrupted() hears: the reason, and for a blow-up the error that stopped the run.
struct Interruption {
  StopReason reason = StopReason::kStopRequested;
  const BlowUpError* blow_up = nullptr;  ///< set for kBlowUp only
};

/// Watches a Simulation. Every hook sees the simulation at the step just taken (Simulation::step);
/// hooks run in the order the observers were attached. Each run() calls start() once, then
/// after_step() after every step, then exactly one of interrupted() and finish() on every
/// observer (an observer attached after one whose start() threw BlowUpError is interrupted
/// without having started). An observer may throw BlowUpError from start() or after_step() to
/// stop the run as a blow-up; any other exception leaves run() with no further hook called.
class Observer {
 public:
  Observer() = default;
  Observer(const Observer&) = delete;
  Observer& operator=(const Observer&) = delete;
  Observer(Observer&&) = delete;
  Observer& operator=(Observer&&) = delete;
  virtual ~Observer() = default;

  /// Before the first step, at the state the run starts from (step 0, or a restart's step).
  virtual void start(const Simulation& /*simulation*/) {}
  /// After each step that completed without a blow-up.
  virtual void after_step(const Simulation& /*simulation*/) {}
  /// Whether after_step() at step @p step (the next one at the latest; asked before it is taken)
  /// reads the particles or the stepper's state (beyond step and time): only then does run()
  /// give the step's closing half-kicks before calling it; at others they merge with the next
  /// step's opening ones and drift, taken as pass 2 of the step ends (Stepper::drift_ahead).
  /// Observers that read at some steps only say which. A step that drifted ahead finds a value
  /// it left not finite in that merged sweep, before its after_step(): interrupted() then names
  /// that step, at the drifted state.
  virtual bool reads_state(const Simulation& /*simulation*/, std::int64_t /*step*/) const {
    return true;
  }
  /// The run ends before its last step, for @p why.
  virtual void interrupted(const Simulation& /*simulation*/, const Interruption& /*why*/) {}
  /// The last step is done (after its after_step()). The stepper's per-pair forces are released
  /// by then (Stepper::release_pair_forces()): the state, the list, the springs and the bond
  /// flags are there, the forces between pairs are not.
  virtual void finish(const Simulation& /*simulation*/) {}
};

/// How run() ended.
struct RunEnd {
  bool finished = false;               ///< the last step was reached
  std::optional<StopReason> stopped;   ///< why not, when not finished
  std::optional<BlowUpError> blow_up;  ///< the error, when stopped by a blow-up
  std::int64_t first_step = 0;         ///< step count when run() began
  std::int64_t step = 0;               ///< step count when it ended
  double loop_seconds = 0.0;           ///< wall time of the steps and their after_step() hooks
};

/// Steps a scene to a given step count and tells its observers. Holds references only: the
/// scene, the stepper, the observers and the stop flag must outlive run().
class Simulation {
 public:
  /// Run @p stepper (which steps @p scene) until its step count reaches @p last_step.
  Simulation(const Scene& scene, Stepper& stepper, std::int64_t last_step);

  /// Add @p observer after the ones attached before it.
  void attach(Observer& observer) { observers_.push_back(&observer); }
  /// Stop after the current step (with interrupted(kStopRequested)) once *@p flag is nonzero; a
  /// flag raised during the last step is not an interruption. Null: never.
  void stop_when(const volatile std::sig_atomic_t* flag) { stop_flag_ = flag; }

  /// Call start(), step to the last step with after_step() after each, then finish(); or end
  /// early with interrupted() on a blow-up or a stop request. A BlowUpError ends the run, it is
  /// not thrown: see RunEnd.
  RunEnd run();

  /// The scene stepped.
  const Scene& scene() const { return scene_; }
  /// The stepper (time, contacts, neighbor list, forces).
  const Stepper& stepper() const { return stepper_; }
  /// Steps taken so far (the stepper's count).
  std::int64_t step() const { return stepper_.step_count(); }
  /// The step the run ends at.
  std::int64_t last_step() const { return last_step_; }
  /// True at the last step.
  bool at_end() const { return step() == last_step_; }

 private:
  /// interrupted() on every observer, in order.
  void interrupt(const Interruption& why) const;

  const Scene& scene_;
  Stepper& stepper_;
  std::int64_t last_step_;
  std::vector<Observer*> observers_;
  const volatile std::sig_atomic_t* stop_flag_ = nullptr;
};

/// True when @p step is a multiple of @p every or the last of @p simulation: the steps at which
/// an output "every N steps" writes (the end always included).
inline bool every_or_last(const Simulation& simulation, std::int64_t step, std::int64_t every) {
  return step % every == 0 || step == simulation.last_step();
}

}  // namespace bondem
