// The run driver: hook order and counts, the two ways a run ends early (a stop request, a
// blow-up) and how observers hear them, and the history observer's rows.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "geometry/boundary.hpp"
#include "run_helpers.hpp"
#include "scene_builders.hpp"
#include "solver/driver/history.hpp"
#include "solver/driver/simulation.hpp"
#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"

namespace bondem {
namespace {

/// Two spheres approaching each other in a box, far from touching for the few steps taken.
Case two_spheres() {
  Case c = testing::soft_case(0.1);
  ParticleSpec a;
  a.radius = 1e-3;
  a.position = Eigen::Vector3d(2e-3, 5e-3, 5e-3);
  a.velocity = Eigen::Vector3d(0.1, 0.0, 0.0);
  ParticleSpec b = a;
  b.position.x() = 8e-3;
  b.velocity.x() = -0.1;
  c.particles = {a, b};
  Domain d;
  d.max = Eigen::Vector3d::Constant(1e-2);
  c.domain = d;
  c.end_time = 1e-5;
  return c;
}

/// A scene, its stepper and a Simulation to @p last_step.
struct Fixture {
  explicit Fixture(std::int64_t last_step, const Case& c = two_spheres())
      : scene(build_scene(c)), stepper(scene), simulation(scene, stepper, last_step) {}
  Scene scene;
  Stepper stepper;
  Simulation simulation;
};

/// Logs every hook as "<name> <hook> <step>" (interrupted adds "stop" or "blow-up: <what>"), and
/// runs @p on_step, if set, at the end of after_step.
class Recorder : public Observer {
 public:
  Recorder(std::string name, std::vector<std::string>& log) : name_(std::move(name)), log_(log) {}
  std::function<void(const Simulation&)> on_start, on_step;

  void start(const Simulation& s) override {
    note("start", s);
    if (on_start) on_start(s);
  }
  void after_step(const Simulation& s) override {
    note("step", s);
    if (on_step) on_step(s);
  }
  void interrupted(const Simulation& s, const Interruption& why) override {
    if (why.reason == StopReason::kStopRequested) {
      note("interrupted stop", s);
    } else {
      ASSERT_NE(why.blow_up, nullptr);
      note(std::string("interrupted blow-up: ") + why.blow_up->what(), s);
    }
  }
  void finish(const Simulation& s) override { note("finish", s); }

 private:
  void note(const std::string& hook, const Simulation& s) {
    log_.push_back(name_ + " " + hook + " " + std::to_string(s.step()));
  }
  std::string name_;
  std::vector<std::string>& log_;
};

TEST(Simulation, HooksRunInOrderOncePerStep) {
  Fixture f(3);
  std::vector<std::string> log;
  Recorder a("a", log), b("b", log);
  f.simulation.attach(a);
  f.simulation.attach(b);
  const RunEnd end = f.simulation.run();
  const std::vector<std::string> expected{"a start 0",  "b start 0", "a step 1", "b step 1",
                                          "a step 2",   "b step 2",  "a step 3", "b step 3",
                                          "a finish 3", "b finish 3"};
  EXPECT_EQ(log, expected);
  EXPECT_TRUE(end.finished);
  EXPECT_FALSE(end.stopped.has_value());
  EXPECT_FALSE(end.blow_up.has_value());
  EXPECT_EQ(end.first_step, 0);
  EXPECT_EQ(end.step, 3);
  EXPECT_EQ(f.stepper.step_count(), 3);
  EXPECT_GE(end.loop_seconds, 0.0);
}

TEST(Simulation, ContinuesFromTheStepperCount) {
  Fixture f(5);
  f.stepper.step();
  f.stepper.step();
  std::vector<std::string> log;
  Recorder a("a", log);
  f.simulation.attach(a);
  const RunEnd end = f.simulation.run();
  const std::vector<std::string> expected{"a start 2", "a step 3", "a step 4", "a step 5",
                                          "a finish 5"};
  EXPECT_EQ(log, expected);
  EXPECT_EQ(end.first_step, 2);
  EXPECT_EQ(end.step, 5);
}

TEST(Simulation, StopRequestInterruptsEveryObserverAndFinishesNone) {
  Fixture f(10);
  volatile std::sig_atomic_t stop = 0;
  f.simulation.stop_when(&stop);
  std::vector<std::string> log;
  Recorder a("a", log), b("b", log);
  a.on_step = [&](const Simulation& s) {
    if (s.step() == 2) stop = 1;  // as a signal handler would, during the step
  };
  f.simulation.attach(a);
  f.simulation.attach(b);
  const RunEnd end = f.simulation.run();
  // The step in progress completes, with all its hooks, before the run stops.
  const std::vector<std::string> expected{"a start 0",
                                          "b start 0",
                                          "a step 1",
                                          "b step 1",
                                          "a step 2",
                                          "b step 2",
                                          "a interrupted stop 2",
                                          "b interrupted stop 2"};
  EXPECT_EQ(log, expected);
  EXPECT_FALSE(end.finished);
  ASSERT_TRUE(end.stopped.has_value());
  EXPECT_EQ(*end.stopped, StopReason::kStopRequested);
  EXPECT_FALSE(end.blow_up.has_value());
  EXPECT_EQ(end.step, 2);
  EXPECT_EQ(f.stepper.step_count(), 2);
}

TEST(Simulation, StopRequestDuringTheLastStepFinishes) {
  Fixture f(2);
  volatile std::sig_atomic_t stop = 0;
  f.simulation.stop_when(&stop);
  std::vector<std::string> log;
  Recorder a("a", log);
  a.on_step = [&](const Simulation& s) {
    if (s.at_end()) stop = 1;
  };
  f.simulation.attach(a);
  const RunEnd end = f.simulation.run();
  EXPECT_TRUE(end.finished);
  EXPECT_EQ(log.back(), "a finish 2");
}

TEST(Simulation, BlowUpFromAnObserverReachesInterruptedWithTheError) {
  Fixture f(10);
  std::vector<std::string> log;
  Recorder a("a", log), b("b", log);
  a.on_step = [](const Simulation& s) {
    if (s.step() == 3) throw BlowUpError("too hot", BlowUpCause::kHeat);
  };
  f.simulation.attach(a);
  f.simulation.attach(b);
  const RunEnd end = f.simulation.run();
  // b's after_step of step 3 never runs: the blow-up ends the step where it is thrown.
  const std::vector<std::string> expected{"a start 0",
                                          "b start 0",
                                          "a step 1",
                                          "b step 1",
                                          "a step 2",
                                          "b step 2",
                                          "a step 3",
                                          "a interrupted blow-up: too hot 3",
                                          "b interrupted blow-up: too hot 3"};
  EXPECT_EQ(log, expected);
  EXPECT_FALSE(end.finished);
  ASSERT_TRUE(end.stopped.has_value());
  EXPECT_EQ(*end.stopped, StopReason::kBlowUp);
  ASSERT_TRUE(end.blow_up.has_value());
  EXPECT_STREQ(end.blow_up->what(), "too hot");
  EXPECT_EQ(end.blow_up->cause(), BlowUpCause::kHeat);
  EXPECT_EQ(end.step, 3);
}

TEST(Simulation, BlowUpAtStartInterruptsObserversNotYetStarted) {
  Fixture f(10);
  std::vector<std::string> log;
  Recorder a("a", log), b("b", log);
  a.on_start = [](const Simulation&) { throw BlowUpError("bad start", BlowUpCause::kTool); };
  f.simulation.attach(a);
  f.simulation.attach(b);
  const RunEnd end = f.simulation.run();
  const std::vector<std::string> expected{"a start 0", "a interrupted blow-up: bad start 0",
                                          "b interrupted blow-up: bad start 0"};
  EXPECT_EQ(log, expected);
  EXPECT_EQ(f.stepper.step_count(), 0);
  ASSERT_TRUE(end.blow_up.has_value());
  EXPECT_EQ(end.blow_up->cause(), BlowUpCause::kTool);
}

TEST(Simulation, OtherErrorsLeaveRunWithNoFurtherHook) {
  Fixture f(10);
  std::vector<std::string> log;
  Recorder a("a", log), b("b", log);
  a.on_step = [](const Simulation& s) {
    if (s.step() == 2) throw std::runtime_error("disk full");
  };
  f.simulation.attach(a);
  f.simulation.attach(b);
  EXPECT_THROW(f.simulation.run(), std::runtime_error);
  EXPECT_EQ(log.back(), "a step 2");
  EXPECT_EQ(f.stepper.step_count(), 2);
}

/// 400 frictional spheres shaken in a box under gravity, walls all round, their spins and
/// displacements tracked: every array the sweeps touch changes every step.
Case frictional_gas() {
  Case c = testing::soft_case(0.2);
  c.contact.friction = 0.5;
  c.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  const double length = 0.009;  // solid fraction 0.29
  testing::add_random_gas(c, 400, 0.4e-3, 0.6e-3, length, 1.0, 31);
  const bool closed[6] = {};
  c.boundaries =
      box_container(Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(length), 0, closed);
  return c;
}

/// Reads the state (positions, velocities, spins, as bytes) every @p every steps only, and
/// notes whether the next step's drift was taken at each step it does not read.
class SparseReader : public Observer {
 public:
  explicit SparseReader(std::int64_t every) : every_(every) {}
  bool reads_state(const Simulation& /*s*/, std::int64_t step) const override {
    return step % every_ == 0;
  }
  void after_step(const Simulation& s) override {
    if (!reads_state(s, s.step())) {
      drifted_steps += s.stepper().drifted() ? 1 : 0;
      return;
    }
    EXPECT_FALSE(s.stepper().drifted()) << "step " << s.step();
    const Particles& p = s.scene().particles;
    for (const auto* field : {&p.x, &p.y, &p.z, &p.vx, &p.vy, &p.vz, &p.wx, &p.wy, &p.wz}) {
      states.emplace_back(reinterpret_cast<const char*>(field->data()),
                          field->size() * sizeof(double));
    }
  }
  std::vector<std::string> states;
  int drifted_steps = 0;

 private:
  std::int64_t every_;
};

TEST(Simulation, StepsDriftedAheadGiveTheBytesOfSettledSteps) {
  // At steps no observer reads, the closing half-kicks are given with the next step's opening
  // ones and its drift as pass 2 ends (Stepper::drift_ahead), by the
  // same operations: the states read must be the bytes of a run that settles every step (an
  // observer reading every step).
  constexpr std::int64_t kSteps = 60;
  Fixture sparse_run(kSteps, frictional_gas());
  Fixture settled_run(kSteps, frictional_gas());
  SparseReader sparse(7), every_step(1);
  sparse_run.simulation.attach(sparse);
  settled_run.simulation.attach(every_step);
  ASSERT_TRUE(sparse_run.simulation.run().finished);
  ASSERT_TRUE(settled_run.simulation.run().finished);
  ASSERT_GT(sparse_run.stepper.contacts().contacts, 0u);
  // Every step not read but the last drifts ahead.
  EXPECT_EQ(sparse.drifted_steps, kSteps - kSteps / 7 - 1);
  EXPECT_EQ(every_step.drifted_steps, 0);
  ASSERT_EQ(sparse.states.size(), 9u * (kSteps / 7));
  for (std::size_t k = 0; k < sparse.states.size(); ++k) {
    // every_step read steps 1, 2, ...; sparse steps 7, 14, ...: the same field of step 7 (r + 1).
    const std::size_t field = k % 9, read = k / 9;
    EXPECT_EQ(sparse.states[k], every_step.states[9 * (7 * (read + 1) - 1) + field])
        << "field " << field << " at step " << 7 * (read + 1);
  }
  // The last step is always settled.
  EXPECT_FALSE(sparse_run.stepper.drifted());
  const Particles& a = sparse_run.scene.particles;
  const Particles& b = settled_run.scene.particles;
  EXPECT_EQ(std::memcmp(a.vx.data(), b.vx.data(), a.size() * sizeof(double)), 0);
  EXPECT_EQ(std::memcmp(a.wz.data(), b.wz.data(), a.size() * sizeof(double)), 0);
}

TEST(Simulation, ABlowUpFoundByTheMergedSweepNamesTheStepItCloses) {
  // A velocity that is not finite shows at the closing sweep of step 1. Drifted ahead, the merged
  // sweep at the end of step 1's pass 2 finds it: the error must still name step 1 and the same
  // particle.
  const auto blow_up = [](std::int64_t every) {
    Fixture f(5, frictional_gas());
    f.scene.particles.vy[3] = std::numeric_limits<double>::quiet_NaN();
    SparseReader reader(every);
    f.simulation.attach(reader);
    return f.simulation.run();
  };
  const RunEnd deferred = blow_up(100), settled = blow_up(1);
  ASSERT_TRUE(deferred.blow_up.has_value());
  ASSERT_TRUE(settled.blow_up.has_value());
  EXPECT_STREQ(deferred.blow_up->what(), settled.blow_up->what());
  EXPECT_NE(std::string(settled.blow_up->what()).find("step 1 "), std::string::npos)
      << settled.blow_up->what();
  EXPECT_EQ(deferred.step, 1);
  EXPECT_EQ(settled.step, 1);
}

/// Reads nothing; raises the stop flag in after_step() at step @p at, as a signal handler might
/// while the next step runs, and logs the steps it hears of.
class StopRequester : public Observer {
 public:
  StopRequester(std::int64_t at, volatile std::sig_atomic_t& flag) : at_(at), flag_(flag) {}
  bool reads_state(const Simulation& /*s*/, std::int64_t /*step*/) const override { return false; }
  void after_step(const Simulation& s) override {
    log.push_back("step " + std::to_string(s.step()));
    if (s.step() != at_) return;
    drifted_at_request = s.stepper().drifted();
    flag_ = 1;
  }
  void interrupted(const Simulation& s, const Interruption& /*why*/) override {
    log.push_back("interrupted " + std::to_string(s.step()));
  }
  std::vector<std::string> log;
  bool drifted_at_request = false;

 private:
  std::int64_t at_;
  volatile std::sig_atomic_t& flag_;
};

TEST(Simulation, AStopRequestDuringADriftAheadStopsAtTheStepItBegan) {
  // A stop request that comes while the particles have drifted into the next step (after step
  // 4, which nobody reads) waits for that step: the run takes step 5, settled, calls its
  // after_step(), and stops there with the bytes of five settled steps.
  constexpr std::int64_t kSteps = 20;
  Fixture stopped(kSteps, frictional_gas()), settled(kSteps, frictional_gas());
  volatile std::sig_atomic_t stop = 0;
  stopped.simulation.stop_when(&stop);
  StopRequester requester(4, stop);
  stopped.simulation.attach(requester);
  const RunEnd end = stopped.simulation.run();
  EXPECT_TRUE(requester.drifted_at_request);
  ASSERT_TRUE(end.stopped.has_value());
  EXPECT_EQ(*end.stopped, StopReason::kStopRequested);
  EXPECT_EQ(end.step, 5);
  const std::vector<std::string> expected{"step 1", "step 2", "step 3",
                                          "step 4", "step 5", "interrupted 5"};
  EXPECT_EQ(requester.log, expected);
  EXPECT_FALSE(stopped.stepper.drifted());
  for (int s = 0; s < 5; ++s) settled.stepper.step();
  const Particles& a = stopped.scene.particles;
  const Particles& b = settled.scene.particles;
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_TRUE(testing::same_motion(a, i, b, i)) << "particle " << i;
  }
}

TEST(History, ExactTextIsPrintfsSeventeenDigits) {
  // exact_text() formats by std::to_chars with precision 17, which C++ defines by printf's
  // "%.17g": checked against printf itself on doubles of every exponent, random bit patterns
  // (NaNs with their signs included) and the special values.
  std::vector<double> values = {0.0,
                                -0.0,
                                0.1,
                                1.0 / 3.0,
                                1e16,
                                1e17,
                                123456789012345678.0,
                                5e-324,
                                2.2250738585072014e-308,
                                std::numeric_limits<double>::max(),
                                std::numeric_limits<double>::infinity(),
                                -std::numeric_limits<double>::infinity(),
                                std::numeric_limits<double>::quiet_NaN(),
                                -std::numeric_limits<double>::quiet_NaN()};
  std::uint64_t bits = 0x9E3779B97F4A7C15ULL;  // a 64-bit LCG: every sign, exponent and mantissa
  for (int k = 0; k < 200000; ++k) {
    bits = bits * 6364136223846793005ULL + 1442695040888963407ULL;
    double value = 0.0;
    std::memcpy(&value, &bits, sizeof value);
    values.push_back(value);
  }
  for (const double value : values) {
    char expected[64];
    std::snprintf(expected, sizeof expected, "%.17g", value);
    ASSERT_EQ(exact_text(value), expected);
  }
}

TEST(History, ExactTextIsPrintfsSeventeenDigitsWhereStatesLie) {
  // The magnitudes of positions, velocities, spins, radii and energies (10^-39 to 10^17) take a
  // faster path than std::to_chars, its own rounding and layout (128-bit products above 10^-11,
  // 192-bit ones below): checked against printf on random mantissas over that whole range and
  // past both ends, on exact ties of the 18th digit at every decimal scale that has them (ties to
  // even; below 10^-8 no double is a tie), at the powers of ten and their neighbours (where the
  // exponent estimate is one off, or rounding carries into an eighteenth digit, such as
  // 9.99999999999999999e16 becoming 1e17), both signs.
  std::vector<double> values;
  std::uint64_t state = 0x2545F4914F6CDD1DULL;
  const auto next = [&state] {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return state;
  };
  for (int binary_exponent = -140; binary_exponent <= 60; ++binary_exponent) {
    for (int k = 0; k < 2000; ++k) {
      const std::uint64_t mantissa = (next() >> 11) | (std::uint64_t{1} << 52);
      values.push_back(std::ldexp(static_cast<double>(mantissa), binary_exponent - 52));
    }
  }
  std::uint64_t power_of_five = 1;
  for (int scale = 0; scale <= 27; ++scale, power_of_five *= 5) {
    // value = odd / 2^(scale + 1) with odd * 5^scale in [2 10^16, 2 10^17): value * 10^scale =
    // odd * 5^scale / 2 has 17 digits before the point and exactly .5 after it, a tie.
    const std::uint64_t lowest = (20'000'000'000'000'000ULL + power_of_five - 1) / power_of_five;
    const std::uint64_t end = std::min<std::uint64_t>(
        (200'000'000'000'000'000ULL + power_of_five - 1) / power_of_five,
        std::uint64_t{1} << 53);  // odd * 5^scale < 2 10^17, odd exact in a double
    const std::uint64_t first_odd = lowest | 1;
    if (first_odd >= end) continue;
    const std::uint64_t odds = (end - first_odd + 1) / 2;
    for (int k = 0; k < 400; ++k) {
      const std::uint64_t odd = first_odd + 2 * (next() % odds);
      values.push_back(std::ldexp(static_cast<double>(odd), -(scale + 1)));
    }
  }
  for (int power = -41; power <= 17; ++power) {
    const double ten = std::pow(10.0, power);
    double below = ten;
    double above = ten;
    for (int k = 0; k < 50; ++k) {
      values.push_back(below);
      values.push_back(above);
      below = std::nextafter(below, 0.0);
      above = std::nextafter(above, 1e300);
    }
  }
  values.push_back(99999999999999999.0);
  values.push_back(9.9999999999999999e-5);
  values.push_back(9.9999999999999999e-6);
  const std::size_t count = values.size();
  for (std::size_t k = 0; k < count; ++k) values.push_back(-values[k]);
  for (const double value : values) {
    char expected[64];
    std::snprintf(expected, sizeof expected, "%.17g", value);
    ASSERT_EQ(exact_text(value), expected) << "bits " << std::bit_cast<std::uint64_t>(value);
  }
}

TEST(History, RowsAtStepZeroEveryIntervalAndTheEnd) {
  Fixture f(7);
  std::string sunk;
  History history(f.scene, 3, [&](const std::string& text) { sunk += text; });
  f.simulation.attach(history);
  f.simulation.run();
  // time, kinetic_energy, rotational_energy, contacts, bonds, bonds_formed, bonds_broken,
  // wall_contacts, max_overlap: no walls, not thermal.
  ASSERT_EQ(history.columns().size(), 9u);
  EXPECT_EQ(history.columns()[1].name, "kinetic_energy");
  EXPECT_STREQ(history.columns()[1].unit, "J");
  const std::string& text = history.text();
  EXPECT_EQ(text, sunk);
  EXPECT_EQ(text.substr(0, text.find('\n') + 1), history_header(history.columns()));
  // Rows at steps 0, 3, 6 and 7 (the end), each starting with its time.
  std::vector<std::string> times;
  for (std::size_t row = text.find('\n') + 1; row < text.size(); row = text.find('\n', row) + 1) {
    times.push_back(text.substr(row, text.find(',', row) - row));
  }
  const double dt = f.scene.time_step;
  const std::vector<std::string> expected{exact_text(0.0), exact_text(3 * dt), exact_text(6 * dt),
                                          exact_text(7 * dt)};
  ASSERT_EQ(times.size(), expected.size()) << text;
  for (std::size_t k = 0; k < times.size(); ++k) {
    // The stepper accumulates time step by step: compare as numbers, to a rounding.
    EXPECT_NEAR(std::stod(times[k]), std::stod(expected[k]), 1e-18) << k;
  }
  EXPECT_EQ(history.last_row_step(), 7);
}

TEST(History, ARestartContinuesItsTextWithoutARowAtTheStart) {
  Fixture f(4);
  f.stepper.step();
  History history(f.scene, 100);
  history.continue_from("time\n0\n");
  f.simulation.attach(history);
  f.simulation.run();
  const std::string& text = history.text();
  EXPECT_EQ(text.rfind("time\n0\n", 0), 0u) << text;
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 3) << text;  // the two, then step 4
  EXPECT_EQ(history.last_row_step(), 4);
}

TEST(History, ANonFiniteTotalIsABlowUpAndItsRowIsNotWritten) {
  Case c = two_spheres();
  c.particles.edit(0).velocity.x() = 1e200;  // finite, but its kinetic energy is not
  Fixture f(5, c);
  std::string sunk;
  History history(f.scene, 1, [&](const std::string& text) { sunk += text; });
  std::vector<std::string> log;
  Recorder after("after", log);
  f.simulation.attach(history);
  f.simulation.attach(after);
  const RunEnd end = f.simulation.run();
  ASSERT_TRUE(end.blow_up.has_value());
  EXPECT_EQ(end.blow_up->cause(), BlowUpCause::kHistory);
  const std::string what = end.blow_up->what();
  EXPECT_NE(what.find("history value kinetic_energy = inf J"), std::string::npos) << what;
  EXPECT_NE(what.find("fastest particle id 0"), std::string::npos) << what;
  EXPECT_EQ(sunk, history_header(history.columns()));  // the header only
  EXPECT_EQ(history.last_row_step(), -1);
  ASSERT_EQ(log.size(), 1u);
  EXPECT_EQ(log[0].rfind("after interrupted blow-up: step 0", 0), 0u) << log[0];
}

}  // namespace
}  // namespace bondem
