#pragma once
/// @file history.hpp
/// The history of a run: its columns, declared once, and the observer that writes its rows.

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "solver/driver/simulation.hpp"
#include "solver/engine/contact_kernel.hpp"
#include "solver/engine/stepper.hpp"

namespace bondem {

/// Shortest exact text of a double ("%.17g"): the same bits always give the same bytes, and the
/// text reads back as the same double.
std::string exact_text(double value);

/// Room exact_text() needs at most: "-1.2345678901234567e-308" and a spare byte.
inline constexpr std::size_t kExactTextChars = 26;

/// Writes exact_text(@p value) at @p out, which has room for kExactTextChars; returns the end.
/// The same bytes as printf's "%.17g" (C++ defines std::to_chars with a precision by it). From
/// 10^-39 to 10^17 the digits come from one exact product (the mantissa times a power of five)
/// and their layout is written directly, elsewhere from std::to_chars. A final state's residual
/// velocities and spins lie below 10^-11 (four values in ten on the settled 998 400 lattice).
char* write_exact_text(char* out, double value);

/// One column of the history: its name, its unit, and how to read it from the run.
struct HistoryColumn {
  std::string name;
  const char* unit;  ///< "" for counts
  std::function<double()> value;
};

/// What a history row reads: the run's totals at one step. A run in one process takes them from
/// its scene and stepper (run_totals()); a decomposed run adds up its ranks' shares.
struct RunTotals {
  double time = 0.0;
  double kinetic_energy = 0.0;     ///< [J]
  double rotational_energy = 0.0;  ///< [J]
  ContactSummary contacts;         ///< of the last force evaluation
  std::int64_t bonds_formed = 0;   ///< so far
  std::int64_t bonds_broken = 0;
  std::size_t particles = 0;
  std::int64_t inserted = 0;     ///< by all streams together, so far
  double inserted_mass = 0.0;    ///< [kg]
  std::int64_t removed = 0;      ///< for leaving the domain, so far
  double removed_mass = 0.0;     ///< [kg]
  double max_temperature = 0.0;  ///< [K] (thermal runs; the surroundings' with no particle)
  double mean_temperature = 0.0;
  double laser_energy = 0.0;        ///< absorbed so far [J]
  std::vector<BoundaryLoad> loads;  ///< per boundary, of the last force evaluation
};

/// The totals of @p scene stepped by @p stepper (all of its particles: a run in one process).
RunTotals run_totals(const Scene& scene, const Stepper& stepper);

/// The columns of the history of @p scene, declared once: the header and every row come from
/// this list, which reads @p totals (those of the row being written). Counts are exact in a
/// double (below 2^53) and print as integers.
std::vector<HistoryColumn> history_columns(const Scene& scene, const RunTotals& totals);

/// The columns of @p columns named in @p names, in that order after `time` (always first; listed
/// or not); empty @p names: all. Throws std::invalid_argument, listing the columns there are, for
/// a name without a column.
std::vector<HistoryColumn> select_history_columns(std::vector<HistoryColumn> columns,
                                                  const std::vector<std::string>& names);

/// The header line of the history (column names, comma-separated, newline-terminated).
std::string history_header(const std::vector<HistoryColumn>& columns);

/// Records a row of every column at the first state (step 0 only: a restart has its rows), every
/// @p every steps and at the last step. Keeps the whole text (what a checkpoint carries) and
/// passes each piece to a sink as it is written (history.csv, live). A value that is not finite
/// is a blow-up: its row is not written and BlowUpError (kHistory) names the column and the
/// fastest particle.
class History : public Observer {
 public:
  /// Receives the text as it grows: at start() the text so far, then each row.
  using Sink = std::function<void(const std::string& text)>;

  /// Columns of @p scene (those named in @p fields, select_history_columns), their rows from the
  /// simulation's run_totals(); the text starts with the header.
  History(const Scene& scene, std::int64_t every, Sink sink = {},
          const std::vector<std::string>& fields = {});

  /// Continue @p text (a restarted run's history, header included) instead of the header alone.
  void continue_from(std::string text) { text_ = std::move(text); }

  /// The header and every row so far.
  const std::string& text() const { return text_; }
  /// The step of the last row written (-1 before the first).
  std::int64_t last_row_step() const { return last_row_step_; }
  /// The columns, in order.
  const std::vector<HistoryColumn>& columns() const { return columns_; }

  /// Append the row of @p totals at step @p step (what after_step() does with run_totals(); a
  /// decomposed run passes its ranks' totals). Returns "" or, when a value is not finite,
  /// "column = value unit" of the first such column, and the row is not written.
  std::string add_row(std::int64_t step, const RunTotals& totals);

  void start(const Simulation& simulation) override;
  void after_step(const Simulation& simulation) override;
  /// At the steps it writes a row: every `every` steps and the last.
  bool reads_state(const Simulation& simulation, std::int64_t step) const override {
    return every_or_last(simulation, step, every_);
  }

 private:
  /// Append the row of the current state. Throws BlowUpError on a value that is not finite.
  void record(const Simulation& simulation);

  RunTotals totals_;  ///< of the row being written; the columns read it
  std::vector<HistoryColumn> columns_;
  std::int64_t every_;
  Sink sink_;
  std::string text_;
  std::int64_t last_row_step_ = -1;
};

}  // namespace bondem
