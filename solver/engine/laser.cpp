#include "solver/engine/laser.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <utility>

namespace bondem {

namespace {

/// Half-width of the deposit window in units of w: the power outside is 1 - erf(3 sqrt2)^2 ~ 4e-9.
constexpr double kWindowHalfWidths = 3.0;
/// Upper bound on columns per side of the window: 512^2 columns cost ~3 MB and a few ms.
constexpr std::size_t kMaxColumnsPerSide = 512;
constexpr std::size_t kNoOwner = std::numeric_limits<std::size_t>::max();
/// A column whose highest particle another process holds (LaserAgreement).
constexpr std::size_t kElsewhere = kNoOwner - 1;

double segment_duration(const LaserSegment& segment) {
  if (!(segment.speed > 0.0) || !std::isfinite(segment.speed)) {
    throw std::invalid_argument("laser segment speed must be a finite positive number");
  }
  return (segment.end - segment.start).norm() / segment.speed;
}

void check_beam(const Laser& laser) {
  if (!(laser.spot_radius > 0.0) || !std::isfinite(laser.spot_radius)) {
    throw std::invalid_argument("laser spot radius must be a finite positive number");
  }
  if (!(laser.power >= 0.0) || !std::isfinite(laser.power)) {
    throw std::invalid_argument("laser power must be a finite non-negative number");
  }
  if (!(laser.absorptivity >= 0.0 && laser.absorptivity <= 1.0)) {
    throw std::invalid_argument("laser absorptivity must lie in [0, 1]");
  }
}

/// Fractions of the beam power on each of @p columns equal strips of width @p h that tile
/// [-half, half] (coordinates relative to the beam centre). Each erf is evaluated once per strip
/// edge, so the strips' fractions telescope to the window's fraction up to rounding.
std::vector<double> strip_fractions(std::size_t columns, double h, double half, double w) {
  std::vector<double> fraction(columns);
  const double scale = std::numbers::sqrt2 / w;
  double previous = std::erf(-scale * half);
  for (std::size_t k = 0; k < columns; ++k) {
    const double edge = -half + static_cast<double>(k + 1) * h;
    const double current = std::erf(scale * edge);
    fraction[k] = 0.5 * (current - previous);
    previous = current;
  }
  return fraction;
}

/// Column indices [first, last] whose centres -half + (k + 1/2) h lie in [lo, hi]; first > last
/// when there are none. Clamped in floating point first so a huge particle cannot overflow.
std::pair<std::size_t, std::size_t> columns_in(double lo, double hi, double h, double half,
                                               std::size_t columns) {
  const double last_column = static_cast<double>(columns) - 1.0;
  const double first = std::clamp(std::ceil((lo + half) / h - 0.5), 0.0, last_column + 1.0);
  const double last = std::clamp(std::floor((hi + half) / h - 0.5), -1.0, last_column);
  if (last < first) return {1, 0};
  return {static_cast<std::size_t>(first), static_cast<std::size_t>(last)};
}

/// Image shifts k (in periods) with |offset + k period| < reach, as [first, last] (first > last
/// when none). A period of 0 means the axis is not periodic: only k = 0, if it is in reach.
std::pair<double, double> images_in_window(double offset, double reach, double period) {
  if (period == 0.0) return std::abs(offset) < reach ? std::pair{0.0, 0.0} : std::pair{1.0, 0.0};
  double first = std::ceil((-reach - offset) / period);
  double last = std::floor((reach - offset) / period);
  // The bounds are strict: drop an image that lands exactly on the edge of reach.
  if (!(std::abs(offset + first * period) < reach)) first += 1.0;
  if (!(std::abs(offset + last * period) < reach)) last -= 1.0;
  return {first, last};
}

}  // namespace

std::optional<Eigen::Vector2d> beam_centre(const Laser& laser, double time) {
  double segment_start = laser.start_time;
  if (!(time >= segment_start)) return std::nullopt;
  for (const LaserSegment& segment : laser.path) {
    const double duration = segment_duration(segment);
    // Same expression as laser_end_time accumulates, so "off at the end time" holds exactly.
    const double segment_end = segment_start + duration;
    if (time < segment_end) {
      const double s = (time - segment_start) / duration;
      return Eigen::Vector2d(segment.start + s * (segment.end - segment.start));
    }
    segment_start = segment_end;
  }
  return std::nullopt;
}

double laser_end_time(const Laser& laser) {
  double end = laser.start_time;
  for (const LaserSegment& segment : laser.path) end = end + segment_duration(segment);
  return end;
}

double beam_fraction(const Eigen::Vector2d& centre, double w, double x0, double x1, double y0,
                     double y1) {
  const double scale = std::numbers::sqrt2 / w;
  const double fx = std::erf(scale * (x1 - centre.x())) - std::erf(scale * (x0 - centre.x()));
  const double fy = std::erf(scale * (y1 - centre.y())) - std::erf(scale * (y0 - centre.y()));
  return 0.25 * fx * fy;
}

LaserDeposit deposit_laser_heat(const double* x, const double* y, const double* z,
                                const double* radius, std::size_t n, const Laser& laser,
                                double time, double* heat_rate, LaserPeriods periods) {
  LaserScratch scratch;
  return deposit_laser_heat(x, y, z, radius, nullptr, n, laser, time, heat_rate, scratch, periods);
}

namespace {

/// Particle images whose disc reaches into the window of half-width @p half around @p centre, into
/// scratch.candidates in index order (then image order) so that ties go to the smaller index;
/// coordinates relative to the beam centre keep the column geometry at full precision. Returns the
/// smallest radius among them (infinite when none).
double collect_candidates(const double* x, const double* y, const double* radius, std::size_t n,
                          const Eigen::Vector2d& centre, double half, LaserPeriods periods,
                          const std::uint8_t* counted, LaserScratch& scratch) {
  std::vector<LaserScratch::Candidate>& candidates = scratch.candidates;
  candidates.clear();
  double r_min = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < n; ++i) {
    const double r = radius[i];
    if (!(r > 0.0) || (counted != nullptr && counted[i] == 0)) continue;
    const auto [x_first, x_last] = images_in_window(x[i] - centre.x(), half + r, periods.x);
    const auto [y_first, y_last] = images_in_window(y[i] - centre.y(), half + r, periods.y);
    for (double ky = y_first; ky <= y_last; ++ky) {
      for (double kx = x_first; kx <= x_last; ++kx) {
        candidates.push_back(
            {i, x[i] - centre.x() + kx * periods.x, y[i] - centre.y() + ky * periods.y});
        r_min = std::min(r_min, r);
      }
    }
  }
  return r_min;
}

/// Columns per side: they resolve both the beam (w / 8) and the smallest visible particle
/// (r_min / 6: against a fine-grid oracle one particle's share is then within about 0.02 P;
/// r_min / 3 gave 0.07 P), rounded up so that they tile the window exactly.
std::size_t column_count(double w, double half, double r_min) {
  const double target = std::min(w / 8.0, r_min / 6.0);
  const double wanted = std::ceil(2.0 * half / target);
  return wanted >= static_cast<double>(kMaxColumnsPerSide)
             ? kMaxColumnsPerSide
             : std::max<std::size_t>(1, static_cast<std::size_t>(wanted));
}

/// Highest sphere surface over each column centre, splatted candidate by candidate, into
/// scratch.top with the owning candidate in scratch.owner; equal tops go to the smaller @p id
/// (with none, to the earlier candidate).
void splat_tops(const double* z, const double* radius, const std::int64_t* id, double half,
                double h, std::size_t columns, LaserScratch& scratch) {
  std::vector<double>& top = scratch.top;
  std::vector<std::size_t>& owner = scratch.owner;
  top.assign(columns * columns, -std::numeric_limits<double>::infinity());
  owner.assign(columns * columns, kNoOwner);
  for (std::size_t slot = 0; slot < scratch.candidates.size(); ++slot) {
    const auto [i, px, py] = scratch.candidates[slot];
    const double r = radius[i];
    const double r2 = r * r;
    const auto [col_first, col_last] = columns_in(px - r, px + r, h, half, columns);
    const auto [row_first, row_last] = columns_in(py - r, py + r, h, half, columns);
    for (std::size_t row = row_first; row <= row_last; ++row) {
      const double dy = -half + (static_cast<double>(row) + 0.5) * h - py;
      for (std::size_t col = col_first; col <= col_last; ++col) {
        const double dx = -half + (static_cast<double>(col) + 0.5) * h - px;
        const double d2 = dx * dx + dy * dy;
        if (!(d2 < r2)) continue;
        const double height = z[i] + std::sqrt(r2 - d2);
        const std::size_t c = row * columns + col;
        // An equal top keeps the earlier (smaller-index) owner unless ids say otherwise.
        const bool tie_won =
            id != nullptr && height == top[c] && id[i] < id[scratch.candidates[owner[c]].index];
        if (height > top[c] || tie_won) {
          top[c] = height;
          owner[c] = slot;
        }
      }
    }
  }
}

/// The processes' columns put together (LaserAgreement): each column keeps this process's owner
/// when its particle is the highest of all, kElsewhere when another process's is, kNoOwner when
/// no particle is over it.
void agree_on_tops(const std::int64_t* id, const LaserAgreement& agreement, LaserScratch& scratch) {
  const std::size_t count = scratch.top.size();
  const auto own_id = [&](std::size_t c) {
    return scratch.owner[c] == kNoOwner ? std::numeric_limits<std::int64_t>::max()
                                        : id[scratch.candidates[scratch.owner[c]].index];
  };
  std::vector<double> top = scratch.top;  // scratch.top keeps this process's own
  std::vector<std::int64_t> top_id(count);
  for (std::size_t c = 0; c < count; ++c) top_id[c] = own_id(c);
  agreement.highest_tops(top, top_id);
  for (std::size_t c = 0; c < count; ++c) {
    if (top[c] == -std::numeric_limits<double>::infinity()) {
      scratch.owner[c] = kNoOwner;
    } else if (scratch.owner[c] == kNoOwner || top[c] != scratch.top[c] || top_id[c] != own_id(c)) {
      scratch.owner[c] = kElsewhere;
    }
  }
}

/// Each column's share of @p absorbed_power (its rectangle's beam_fraction, factored as x strip
/// times y strip) to its owner's heat_rate (absorbed elsewhere: another process's particle's), or
/// to the missed power.
LaserDeposit share_power(double absorbed_power, double half, double h, double w,
                         std::size_t columns, LaserScratch& scratch, double* heat_rate) {
  const std::vector<double> fraction = strip_fractions(columns, h, half, w);
  std::vector<double>& gained = scratch.gained;
  gained.assign(scratch.candidates.size(), 0.0);
  LaserDeposit deposit;
  for (std::size_t row = 0; row < columns; ++row) {
    const double row_power = absorbed_power * fraction[row];
    for (std::size_t col = 0; col < columns; ++col) {
      const double share = row_power * fraction[col];
      const std::size_t slot = scratch.owner[row * columns + col];
      if (slot == kNoOwner) {
        deposit.missed += share;
      } else {
        if (slot != kElsewhere) gained[slot] += share;
        deposit.absorbed += share;
      }
    }
  }
  for (std::size_t slot = 0; slot < scratch.candidates.size(); ++slot) {
    heat_rate[scratch.candidates[slot].index] += gained[slot];
  }
  return deposit;
}

}  // namespace

LaserDeposit deposit_laser_heat(const double* x, const double* y, const double* z,
                                const double* radius, const std::int64_t* id, std::size_t n,
                                const Laser& laser, double time, double* heat_rate,
                                LaserScratch& scratch, LaserPeriods periods,
                                const std::uint8_t* counted, const LaserAgreement* agreement) {
  check_beam(laser);
  if ((counted == nullptr) != (agreement == nullptr) || (agreement != nullptr && id == nullptr)) {
    throw std::invalid_argument("laser deposit: counted particles need an agreement and ids");
  }
  if (!(periods.x >= 0.0) || !(periods.y >= 0.0)) {
    throw std::invalid_argument("laser periods must be non-negative (0: not periodic)");
  }
  const std::optional<Eigen::Vector2d> centre = beam_centre(laser, time);
  if (!centre) return {};
  const double w = laser.spot_radius;
  const double half = kWindowHalfWidths * w;
  double r_min = collect_candidates(x, y, radius, n, *centre, half, periods, counted, scratch);
  if (agreement != nullptr) agreement->smallest_radius(r_min);
  const std::size_t columns = column_count(w, half, r_min);
  const double h = 2.0 * half / static_cast<double>(columns);
  splat_tops(z, radius, id, half, h, columns, scratch);
  if (agreement != nullptr) agree_on_tops(id, *agreement, scratch);
  return share_power(laser.absorptivity * laser.power, half, h, w, columns, scratch, heat_rate);
}

}  // namespace bondem
