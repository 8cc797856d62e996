#include "solver/driver/history.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <sstream>

#include "solver/engine/exact_sum.hpp"

namespace bondem {

namespace {

__extension__ using Uint128 = unsigned __int128;  // GCC and Clang: exact 64 x 64-bit products

/// 5^k for k = 0..55: the powers within 128 bits (times a 53-bit mantissa, within 192).
constexpr std::array<Uint128, 56> kPowersOfFive = [] {
  std::array<Uint128, 56> powers{};
  Uint128 power = 1;
  for (Uint128& p : powers) {
    p = power;
    power *= 5;
  }
  return powers;
}();

constexpr std::uint64_t kSeventeenDigitsLow = 10'000'000'000'000'000ULL;   // 10^16
constexpr std::uint64_t kSeventeenDigitsEnd = 100'000'000'000'000'000ULL;  // 10^17

/// An unsigned integer of 192 bits, least significant word first: a 53-bit mantissa times a
/// power of five of up to 128 bits.
struct Uint192 {
  std::array<std::uint64_t, 3> words{};

  /// @p mantissa times @p power, exactly.
  static Uint192 product(std::uint64_t mantissa, Uint128 power) {
    const Uint128 low = static_cast<Uint128>(static_cast<std::uint64_t>(power)) * mantissa;
    const Uint128 high = static_cast<Uint128>(static_cast<std::uint64_t>(power >> 64)) * mantissa;
    const Uint128 middle = (low >> 64) + static_cast<std::uint64_t>(high);
    return {{static_cast<std::uint64_t>(low), static_cast<std::uint64_t>(middle),
             static_cast<std::uint64_t>((middle >> 64) + (high >> 64))}};
  }
  /// Bit @p k (0 to 191).
  bool bit(int k) const { return ((words[static_cast<std::size_t>(k / 64)] >> (k % 64)) & 1) != 0; }
  /// Whether any of bits 0 to @p k - 1 is set.
  bool any_below(int k) const {
    for (int word = 0; word < 3; ++word) {
      const int first = 64 * word;
      if (k <= first) return false;
      const std::uint64_t w = words[static_cast<std::size_t>(word)];
      if ((k >= first + 64 ? w : w & ((std::uint64_t{1} << (k - first)) - 1)) != 0) return true;
    }
    return false;
  }
  /// The value shifted right by @p right (0 to 191) bits, as 128 bits (the caller's quotients
  /// are below 2^64).
  Uint128 shifted_right(int right) const {
    const auto word = static_cast<std::size_t>(right / 64);
    const int within = right % 64;
    Uint128 result = 0;
    for (std::size_t k = word; k < 3; ++k) {
      const Uint128 w = words[k];
      const int place = static_cast<int>(64 * (k - word)) - within;
      result |= place >= 0 ? (place < 128 ? w << place : 0) : w >> -place;
    }
    return result;
  }
};

/// The 17 significant digits of finite, non-zero |@p value| rounded as printf rounds them (to
/// nearest, ties to even, from the exact binary value), as an integer in [10^16, 10^17), and the
/// decimal exponent of the first; false outside 10^-39 <= |value| < 10^17, where the scaling
/// below would leave 192 bits (std::to_chars formats those).
bool seventeen_digits(double value, std::uint64_t& digits, int& exponent) {
  const auto bits = std::bit_cast<std::uint64_t>(value);
  const int biased = static_cast<int>((bits >> 52) & 0x7ff);
  // Zero, subnormals, infinities and NaN; below 2^-132 (2 10^-40) and from 2^57 (> 10^17) on.
  if (biased <= 890 || biased >= 1080) return false;
  const std::uint64_t mantissa = (bits & ((std::uint64_t{1} << 52) - 1)) | (std::uint64_t{1} << 52);
  const int binary_exponent = biased - 1075;  // |value| = mantissa * 2^binary_exponent
  // floor(log10 2^(biased - 1023)) (log10 2 as 78913 / 2^18), or one more where the estimate's
  // error (under 10^-4 in this range) lifts it past an integer: |value| is within a decade of
  // 10^exponent, which the loop corrects.
  exponent = ((biased - 1023) * 78913) >> 18;
  for (int attempt = 0; attempt < 3; ++attempt) {
    const int scale = 16 - exponent;  // |value| * 10^scale = mantissa * 5^scale * 2^(scale + e)
    if (scale < 0 || scale >= static_cast<int>(kPowersOfFive.size())) return false;
    const Uint192 product =
        Uint192::product(mantissa, kPowersOfFive[static_cast<std::size_t>(scale)]);
    const int shift = scale + binary_exponent;
    Uint128 quotient = 0;
    bool round_up = false;
    if (shift >= 0) {
      if (shift > 8) return false;                   // never in range: |value| < 10^17 < 2^57
      quotient = product.shifted_right(0) << shift;  // an integer (below 2^117): nothing to round
    } else {
      // A product of up to 181 bits (scale 55, 10^-39) shifted right to its 17 digits.
      const int right = -shift;
      if (right > 191) return false;
      quotient = product.shifted_right(right);
      // Above half: the first bit dropped and another; exactly half (ties to even): that one alone.
      round_up = product.bit(right - 1) && (product.any_below(right - 1) || (quotient & 1) != 0);
    }
    if (quotient < kSeventeenDigitsLow) {
      --exponent;
      continue;
    }
    if (quotient >= kSeventeenDigitsEnd) {
      ++exponent;
      continue;
    }
    digits = static_cast<std::uint64_t>(quotient) + (round_up ? 1 : 0);
    if (digits == kSeventeenDigitsEnd) {  // 99...9 rounded up to 10^17: one digit more
      digits = kSeventeenDigitsLow;
      ++exponent;
    }
    return exponent <= 16;  // 10^17 itself: %g's exponent form, left to std::to_chars
  }
  return false;
}

/// "00" to "99".
constexpr std::array<char, 200> kDigitPairs = [] {
  std::array<char, 200> pairs{};
  for (std::size_t k = 0; k < 100; ++k) {
    pairs[2 * k] = static_cast<char>('0' + k / 10);
    pairs[2 * k + 1] = static_cast<char>('0' + k % 10);
  }
  return pairs;
}();

/// The eight decimal digits of @p value < 10^8, leading zeros included, at @p out.
void write_eight_digits(char* out, std::uint32_t value) {
  for (int pair = 3; pair >= 0; --pair) {
    std::memcpy(out + 2 * pair, kDigitPairs.data() + 2 * (value % 100), 2);
    value /= 100;
  }
}

}  // namespace

char* write_exact_text(char* out, double value) {
  // printf's "%.17g" of the 17 digits, as std::to_chars would write them (a final state's values
  // 2.6 times as fast on average); std::to_chars for the rest.
  std::uint64_t digits = 0;
  int exponent = 0;
  if (!seventeen_digits(value, digits, exponent)) {
    return std::to_chars(out, out + kExactTextChars, value, std::chars_format::general, 17).ptr;
  }
  // The digits two at a time, in three independent parts: 1 + 8 + 8.
  char text[17];
  const std::uint64_t high = digits / 100'000'000;
  const auto low = static_cast<std::uint32_t>(digits % 100'000'000);
  text[0] = static_cast<char>('0' + high / 100'000'000);
  write_eight_digits(text + 1, static_cast<std::uint32_t>(high % 100'000'000));
  write_eight_digits(text + 9, low);
  int last = 16;  // %g drops the fraction's trailing zeros
  while (last > 0 && text[last] == '0') --last;
  if (std::signbit(value)) *out++ = '-';
  if (exponent < -4) {  // d.ddde-XX: two exponent digits at least
    *out++ = text[0];
    if (last > 0) {
      *out++ = '.';
      out = std::copy(text + 1, text + last + 1, out);
    }
    const int magnitude = -exponent;  // 5 to 39: seventeen_digits stops at 10^-39
    *out++ = 'e';
    *out++ = '-';
    *out++ = static_cast<char>('0' + magnitude / 10);
    *out++ = static_cast<char>('0' + magnitude % 10);
    return out;
  }
  if (exponent < 0) {  // 0.000ddd
    *out++ = '0';
    *out++ = '.';
    out = std::fill_n(out, -exponent - 1, '0');
    return std::copy(text, text + last + 1, out);
  }
  out = std::copy(text, text + exponent + 1, out);  // the integer part
  if (last > exponent) {
    *out++ = '.';
    out = std::copy(text + exponent + 1, text + last + 1, out);
  }
  return out;
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
  if (reads_state(simulation, simulation.step())) record(simulation);
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
