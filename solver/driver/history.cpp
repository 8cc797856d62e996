#include "solver/driver/history.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <sstream>

#include "solver/engine/exact_sum.hpp"

namespace bondem {

char* write_exact_text(char* out, double value) {
  return std::to_chars(out, out + kExactTextChars, value, std::chars_format::general, 17).ptr;
}

std::string exact_text(double value) {
  char buffer[kExactTextChars];
  return {buffer, write_exact_text(buffer, value)};
}

RunTotals run_totals(const Scene& scene, const Stepper& stepper) {
  RunTotals totals;
  totals.time = stepper.time();
  totals.kinetic_energy = stepper.kinetic_energy();
  totals.rotational_energy = stepper.rotational_energy();
  totals.contacts = stepper.contacts();
  totals.bonds_formed = stepper.bonds_formed();
  totals.bonds_broken = stepper.bonds_broken();
  totals.particles = scene.particles.size();
  for (const ParticleTally& s : stepper.streams()) {
    totals.inserted += s.count;
    totals.inserted_mass += s.mass;
  }
  totals.removed = stepper.removed().count;
  totals.removed_mass = stepper.removed().mass;
  if (scene.particles.thermal()) {
    // A stream's run may start with no particle: the surroundings' temperature stands in.
    const auto& t = scene.particles.temperature;
    totals.max_temperature = scene.ambient_temperature;
    totals.mean_temperature = scene.ambient_temperature;
    if (!t.empty()) {
      totals.max_temperature = *std::max_element(t.begin(), t.end());
      ExactSum sum;  // exact: any thread count and any particle order
      for (const double value : t) sum.add(value);
      totals.mean_temperature = sum.value() / static_cast<double>(t.size());
    }
    totals.laser_energy = stepper.laser_energy();
  }
  totals.loads = stepper.boundary_loads();
  return totals;
}

std::vector<HistoryColumn> history_columns(const Scene& scene, const RunTotals& totals) {
  const auto count = [](auto n) { return static_cast<double>(n); };
  const RunTotals& t = totals;
  std::vector<HistoryColumn> columns{
      {"time", "s", [&t] { return t.time; }},
      {"kinetic_energy", "J", [&t] { return t.kinetic_energy; }},
      {"rotational_energy", "J", [&t] { return t.rotational_energy; }},
      {"contacts", "", [&t, count] { return count(t.contacts.contacts); }},
      {"bonds", "", [&t, count] { return count(t.contacts.bonds); }},
      {"bonds_formed", "", [&t, count] { return count(t.bonds_formed); }},
      {"bonds_broken", "", [&t, count] { return count(t.bonds_broken); }},
      {"wall_contacts", "", [&t, count] { return count(t.contacts.wall_contacts); }},
      {"max_overlap", "m", [&t] { return t.contacts.max_overlap; }}};
  if (!scene.streams.empty()) {
    // Particles in the run, and what the streams added: count and mass, all streams together.
    columns.push_back({"particles", "", [&t, count] { return count(t.particles); }});
    columns.push_back({"inserted", "", [&t, count] { return count(t.inserted); }});
    columns.push_back({"inserted_mass", "kg", [&t] { return t.inserted_mass; }});
  }
  if (scene.domain.remove_outside) {
    columns.push_back({"removed", "", [&t, count] { return count(t.removed); }});
    columns.push_back({"removed_mass", "kg", [&t] { return t.removed_mass; }});
  }
  if (scene.particles.thermal()) {
    columns.push_back({"max_temperature", "K", [&t] { return t.max_temperature; }});
    columns.push_back({"mean_temperature", "K", [&t] { return t.mean_temperature; }});
    columns.push_back({"laser_energy", "J", [&t] { return t.laser_energy; }});
  }
  // The force the particles exert on each boundary, then its moment about its reference point.
  for (std::size_t k = 0; k < scene.boundaries.size(); ++k) {
    const std::string& name = scene.boundaries[k].name;
    for (const int axis : {0, 1, 2}) {
      columns.push_back({"load_" + name + "_" + "xyz"[axis], "N",
                         [&t, k, axis] { return t.loads[k].force[axis]; }});
    }
  }
  for (std::size_t k = 0; k < scene.boundaries.size(); ++k) {
    const std::string& name = scene.boundaries[k].name;
    for (const int axis : {0, 1, 2}) {
      columns.push_back({"moment_" + name + "_" + "xyz"[axis], "N m",
                         [&t, k, axis] { return t.loads[k].moment[axis]; }});
    }
  }
  return columns;
}

std::string history_header(const std::vector<HistoryColumn>& columns) {
  std::string header;
  for (const HistoryColumn& column : columns) header += (header.empty() ? "" : ",") + column.name;
  return header + '\n';
}

std::vector<HistoryColumn> select_history_columns(std::vector<HistoryColumn> columns,
                                                  const std::vector<std::string>& names) {
  if (names.empty()) return columns;
  const auto named = [&](const std::string& name) {
    return std::find_if(columns.begin(), columns.end(),
                        [&](const HistoryColumn& c) { return c.name == name; });
  };
  std::vector<HistoryColumn> selected{*named("time")};
  for (const std::string& name : names) {
    const auto column = named(name);
    if (column == columns.end()) {
      std::string available;
      for (const HistoryColumn& c : columns) available += (available.empty() ? "" : ", ") + c.name;
      throw std::invalid_argument("no history column '" + name + "' in this run (it has " +
                                  available + ")");
    }
    if (name != "time") selected.push_back(*column);
  }
  return selected;
}

History::History(const Scene& scene, std::int64_t every, Sink sink,
                 const std::vector<std::string>& fields)
    : columns_(select_history_columns(history_columns(scene, totals_), fields)),
      every_(every),
      sink_(std::move(sink)),
      text_(history_header(columns_)) {}

void History::start(const Simulation& simulation) {
  if (sink_) sink_(text_);
  if (simulation.step() == 0) record(simulation);
}

void History::after_step(const Simulation& simulation) {
  if (reads_state(simulation)) record(simulation);
}

namespace {

/// The BlowUpError of a history value that is not finite (@p non_finite: "column = value unit"),
/// naming the fastest particle, since a total overflows first where one particle runs away.
BlowUpError non_finite_history(const Simulation& simulation, const std::string& non_finite) {
  std::ostringstream message;
  message << "step " << simulation.step() << " (t = " << simulation.stepper().time()
          << " s): history value " << non_finite;
  const Particles& p = simulation.scene().particles;
  std::size_t fastest = 0;
  double fastest_speed_sq = -1.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double speed_sq = p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i] + p.vz[i] * p.vz[i];
    if (speed_sq > fastest_speed_sq || (std::isnan(speed_sq) && !std::isnan(fastest_speed_sq))) {
      fastest = i;
      fastest_speed_sq = speed_sq;
    }
  }
  if (p.size() > 0) {
    message << "; fastest particle id " << p.id[fastest] << " at " << std::sqrt(fastest_speed_sq)
            << " m/s";
  }
  return BlowUpError(message.str(), BlowUpCause::kHistory);
}

}  // namespace

void History::record(const Simulation& simulation) {
  const std::string non_finite =
      add_row(simulation.step(), run_totals(simulation.scene(), simulation.stepper()));
  if (!non_finite.empty()) throw non_finite_history(simulation, non_finite);
}

std::string History::add_row(std::int64_t step, const RunTotals& totals) {
  totals_ = totals;
  std::ostringstream row;
  std::string non_finite;  // the first column that is not finite
  for (const HistoryColumn& column : columns_) {
    const double value = column.value();
    row << (&column == &columns_.front() ? "" : ",") << exact_text(value);
    if (non_finite.empty() && !std::isfinite(value)) {
      non_finite =
          column.name + " = " + exact_text(value) + (*column.unit ? " " : "") + column.unit;
    }
  }
  row << '\n';
  if (!non_finite.empty()) return non_finite;
  const std::string line = row.str();
  text_ += line;
  last_row_step_ = step;
  if (sink_) sink_(line);
  return "";
}

}  // namespace bondem
