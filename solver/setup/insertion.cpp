#include "solver/setup/insertion.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <functional>
#include <numbers>
#include <sstream>
#include <utility>

#include "solver/engine/particles.hpp"

namespace bondem {
namespace {

/// Cut-offs that reject this many draws in a row hold too little of the distribution to be meant.
constexpr int kMaxRedraws = 10000;

double sphere_volume(double r) {
  return 4.0 / 3.0 * std::numbers::pi * r * r * r;
}

std::string box_text(const Box& b) {
  std::ostringstream s;
  s << "[" << b.min.x() << ", " << b.max.x() << "] x [" << b.min.y() << ", " << b.max.y() << "] x ["
    << b.min.z() << ", " << b.max.z() << "]";
  return s.str();
}

void validate_box(const Box& b, const char* who) {
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(b.min[a]) || !std::isfinite(b.max[a]) || !(b.min[a] < b.max[a])) {
      throw std::invalid_argument(std::string(who) + ": region " + box_text(b) +
                                  " must have min < max on every axis");
    }
  }
}

double smallest_extent(const Box& b) {
  return (b.max - b.min).minCoeff();
}

/// Smallest and largest radius the distribution can produce; 0 for a side without a bound.
std::pair<double, double> radius_bounds(const RadiusDistribution& d) {
  if (d.kind == RadiusDistribution::Kind::kConstant) return {d.value, d.value};
  return {d.min, d.max};  // the cut-offs; 0 (none) for an uncut normal or log-normal
}

double raw_draw(const RadiusDistribution& d, Rng& rng) {
  switch (d.kind) {
    case RadiusDistribution::Kind::kConstant:
      return d.value;
    case RadiusDistribution::Kind::kUniform:
      return d.min + uniform01(rng) * (d.max - d.min);
    case RadiusDistribution::Kind::kNormal:
      return d.mean + d.std_dev * standard_normal(rng);
    case RadiusDistribution::Kind::kLogNormal:
      return d.median * std::exp(d.sigma * standard_normal(rng));
  }
  return 0.0;
}

bool inside_cutoffs(const RadiusDistribution& d, double r) {
  if (d.kind == RadiusDistribution::Kind::kConstant ||
      d.kind == RadiusDistribution::Kind::kUniform) {
    return true;  // the draw itself stays inside; rounding at max is harmless
  }
  return r > 0.0 && r >= d.min && (d.max == 0.0 || r <= d.max);
}

/// Sphere as the overlap test sees it.
struct Sphere {
  double x, y, z, r;
};

/// Uniform cell grid over the region with linked lists of entries per cell, filled while spheres
/// are placed. Entries hold a copy of their sphere: with random positions every entry visited is a
/// cache miss, and one miss per entry instead of two (entry, then sphere) halves the fill time.
class CellGrid {
 public:
  CellGrid(const Box& region, std::array<std::size_t, 3> cells) : lo_(region.min), n_(cells) {
    for (int a = 0; a < 3; ++a) {
      size_[a] = (region.max[a] - region.min[a]) / static_cast<double>(n_[a]);
    }
    head_.assign(n_[0] * n_[1] * n_[2], kNone);
  }

  /// Cell coordinate of @p v along axis @p a, clamped to the grid: clamping keeps neighbors
  /// within one cell, so spheres centered just outside the region are still found.
  std::size_t coordinate(int a, double v) const {
    const double c = std::floor((v - lo_[a]) / size_[a]);
    if (!(c > 0.0)) return 0;  // also catches NaN
    const double last = static_cast<double>(n_[a] - 1);
    return static_cast<std::size_t>(std::min(c, last));
  }

  /// Smallest cell edge: spheres closer than this are in the same or adjacent cells.
  double min_cell_size() const { return std::min({size_[0], size_[1], size_[2]}); }

  void add(std::size_t cx, std::size_t cy, std::size_t cz, const Sphere& sphere) {
    const std::size_t cell = index(cx, cy, cz);
    entries_.push_back({sphere, head_[cell]});
    head_[cell] = static_cast<std::int64_t>(entries_.size() - 1);
  }

  /// Call @p visit(sphere) for every entry of cell (cx, cy, cz); stops when it returns true.
  template <class Visit>
  bool any_in_cell(std::size_t cx, std::size_t cy, std::size_t cz, Visit&& visit) const {
    for (std::int64_t e = head_[index(cx, cy, cz)]; e != kNone;
         e = entries_[static_cast<std::size_t>(e)].next) {
      if (visit(entries_[static_cast<std::size_t>(e)].sphere)) return true;
    }
    return false;
  }

  void reserve(std::size_t entries) { entries_.reserve(entries); }

 private:
  static constexpr std::int64_t kNone = -1;
  struct Entry {
    Sphere sphere;
    std::int64_t next;
  };
  std::size_t index(std::size_t cx, std::size_t cy, std::size_t cz) const {
    return (cz * n_[1] + cy) * n_[0] + cx;
  }

  Eigen::Vector3d lo_;
  std::array<std::size_t, 3> n_;
  std::array<double, 3> size_{};
  std::vector<std::int64_t> head_;
  std::vector<Entry> entries_;
};

/// Cells per axis with edges >= @p min_edge and at most about @p max_cells cells in total, so a
/// few tiny particles in a huge box do not allocate a huge grid.
std::array<std::size_t, 3> grid_cells(const Box& region, double min_edge, double max_cells) {
  const Eigen::Vector3d extent = region.max - region.min;
  double edge = std::max(min_edge, std::cbrt(extent.prod() / max_cells));
  std::array<std::size_t, 3> n{};
  for (;;) {
    double total = 1.0;
    for (int a = 0; a < 3; ++a) {
      const double k = std::max(1.0, std::floor(extent[a] / edge));
      total *= k;
      n[static_cast<std::size_t>(a)] = static_cast<std::size_t>(k);
    }
    if (total <= max_cells) return n;
    edge *= 1.5;  // only thin, elongated regions get here
  }
}

std::string fraction_text(double f) {
  std::ostringstream s;
  s.precision(4);
  s << f;
  return s.str();
}

[[noreturn]] void refuse_too_dense(const std::string& what, double fraction) {
  throw InsertionError("random fill: " + what + " " + fraction_text(fraction) + " is above " +
                       fraction_text(kMaxRandomFillSolidFraction) +
                       ", which random sequential addition cannot reach (it jams near 0.30-0.38"
                       " solid fraction); insert a looser packing, then pour and settle it under"
                       " gravity");
}

}  // namespace

double uniform01(Rng& rng) {
  return static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

double standard_normal(Rng& rng) {
  // 1 - u lies in (0, 1], so the logarithm is finite.
  const double u1 = 1.0 - uniform01(rng);
  const double u2 = uniform01(rng);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
}

void validate(const RadiusDistribution& d) {
  const auto fail = [](const std::string& message) {
    throw std::invalid_argument("radius distribution: " + message);
  };
  const auto finite = [](double v) { return std::isfinite(v); };
  if (!finite(d.value) || !finite(d.min) || !finite(d.max) || !finite(d.mean) ||
      !finite(d.std_dev) || !finite(d.median) || !finite(d.sigma)) {
    fail("parameters must be finite");
  }
  switch (d.kind) {
    case RadiusDistribution::Kind::kConstant:
      if (!(d.value > 0.0)) fail("constant radius must be > 0");
      return;
    case RadiusDistribution::Kind::kUniform:
      if (!(d.min > 0.0)) fail("uniform min must be > 0");
      if (!(d.min < d.max)) fail("uniform needs min < max");
      return;
    case RadiusDistribution::Kind::kNormal:
      if (!(d.mean > 0.0)) fail("normal mean must be > 0");
      if (!(d.std_dev > 0.0)) fail("normal std_dev must be > 0 (use kConstant for none)");
      break;
    case RadiusDistribution::Kind::kLogNormal:
      if (!(d.median > 0.0)) fail("log-normal median must be > 0");
      if (!(d.sigma > 0.0)) fail("log-normal sigma must be > 0 (use kConstant for none)");
      break;
  }
  if (d.min < 0.0) fail("cut-off min must be >= 0 (0 = none)");
  if (d.max < 0.0) fail("cut-off max must be >= 0 (0 = none)");
  if (d.max > 0.0 && !(d.min < d.max)) fail("cut-offs need min < max");
}

RadiusDistribution lognormal_from_d_values(double d10, double d50, double d90,
                                           SizeWeighting weighting) {
  if (!(std::isfinite(d10) && std::isfinite(d90) && d10 > 0.0 && d10 < d50 && d50 < d90)) {
    throw std::invalid_argument("radius distribution: needs 0 < d10 < d50 < d90");
  }
  // ln D90 - ln D10 spans 2 z_0.9 standard deviations of ln d (and of ln r).
  constexpr double kZ90 = 1.2815515655446004;
  RadiusDistribution d;
  d.kind = RadiusDistribution::Kind::kLogNormal;
  d.sigma = std::log(d90 / d10) / (2.0 * kZ90);
  // The volume-weighted distribution of a log-normal is log-normal with the same σ and its
  // median shifted by exp(3σ²) (moments of exp(3 ln r)).
  const double shift =
      weighting == SizeWeighting::kVolume ? std::exp(-3.0 * d.sigma * d.sigma) : 1.0;
  d.median = 0.5 * d50 * shift;
  return d;
}

double draw_radius(const RadiusDistribution& distribution, Rng& rng) {
  validate(distribution);
  for (int k = 0; k < kMaxRedraws; ++k) {
    const double r = raw_draw(distribution, rng);
    if (inside_cutoffs(distribution, r)) return r;
  }
  throw std::invalid_argument("radius distribution: cut-offs [" + std::to_string(distribution.min) +
                              ", " + std::to_string(distribution.max) + "] rejected " +
                              std::to_string(kMaxRedraws) +
                              " draws in a row; they hold almost none of the distribution");
}

std::array<double, 3> lattice_counts(const Box& region, double spacing, double radius) {
  validate_box(region, "lattice");
  if (!(spacing > 0.0) || !std::isfinite(spacing)) {
    throw std::invalid_argument("lattice: spacing must be > 0");
  }
  if (!(radius > 0.0) || !std::isfinite(radius)) {
    throw std::invalid_argument("lattice: radius must be > 0");
  }
  if (2.0 * radius > smallest_extent(region)) {
    throw std::invalid_argument("lattice: a sphere of radius " + std::to_string(radius) +
                                " does not fit the region " + box_text(region));
  }
  // Count rather than step while inside, so rounding cannot add or drop a layer; the small
  // tolerance keeps the layer that touches the far wall exactly (e.g. 5 spheres of r = 0.1 in 1).
  std::array<double, 3> n{};
  for (int a = 0; a < 3; ++a) {
    const double room = (region.max[a] - region.min[a] - 2.0 * radius) / spacing;
    n[static_cast<std::size_t>(a)] = std::floor(room + 1e-9) + 1.0;
  }
  return n;
}

LatticeBlock lattice_block(const Box& region, double spacing, double radius, int material) {
  const std::array<double, 3> counts = lattice_counts(region, spacing, radius);
  if (material < 0) throw std::invalid_argument("lattice: material index must be >= 0");
  const double total = counts[0] * counts[1] * counts[2];
  if (!(total <= kMaxInsertedParticles)) {
    std::ostringstream m;
    m << "lattice: " << counts[0] << " x " << counts[1] << " x " << counts[2] << " = " << total
      << " particles exceed the limit of " << kMaxInsertedParticles
      << " per insertion; raise the spacing or shrink the region";
    throw std::invalid_argument(m.str());
  }
  LatticeBlock block;
  block.origin = region.min + Eigen::Vector3d::Constant(radius);
  block.spacing = spacing;
  block.radius = radius;
  block.material = material;
  for (std::size_t a = 0; a < 3; ++a) block.counts[a] = static_cast<std::size_t>(counts[a]);
  return block;
}

std::vector<ParticleSpec> insert_lattice(const Box& region, double spacing, double radius,
                                         int material) {
  const LatticeBlock block = lattice_block(region, spacing, radius, material);
  std::vector<ParticleSpec> out;
  out.reserve(block.size());
  for (std::size_t k = 0; k < block.size(); ++k) out.push_back(block.at(k));
  return out;
}

/// The checks of a fill request that need no drawing: ranges, targets, and counts whose spheres
/// could not fit even at their smallest. Throws std::invalid_argument.
void validate_fill(const FillRequest& request) {
  const Box& region = request.region;
  validate_box(region, "random fill");
  validate(request.radius);
  if (request.material < 0) throw std::invalid_argument("random fill: material must be >= 0");
  if (!request.velocity.allFinite()) throw std::invalid_argument("random fill: velocity");
  if (!std::isfinite(request.solid_fraction) || request.solid_fraction < 0.0 ||
      request.solid_fraction >= 1.0) {
    throw std::invalid_argument("random fill: solid_fraction must be in [0, 1), 0 = unused");
  }
  if ((request.count > 0) == (request.solid_fraction > 0.0)) {
    throw std::invalid_argument(
        "random fill: give exactly one target, count > 0 or solid_fraction > 0");
  }
  if (request.max_attempts_per_particle == 0) {
    throw std::invalid_argument("random fill: max_attempts_per_particle must be >= 1");
  }
  const double half_room = 0.5 * smallest_extent(region);
  const double bound = radius_bounds(request.radius).second;
  if (bound > half_room) {
    throw std::invalid_argument("random fill: radius up to " + std::to_string(bound) +
                                " does not fit the region " + box_text(region));
  }
  if (request.solid_fraction > kMaxRandomFillSolidFraction) {
    refuse_too_dense("target solid fraction", request.solid_fraction);
  }
  const double region_volume = region.volume();
  if (static_cast<double>(request.count) > kMaxInsertedParticles) {
    std::ostringstream m;
    m << "random fill: count " << request.count << " exceeds the limit of " << kMaxInsertedParticles
      << " per insertion";
    throw std::invalid_argument(m.str());
  }
  // Refuse a count whose spheres cannot fit at their smallest possible size before drawing them.
  const double smallest_volume = sphere_volume(radius_bounds(request.radius).first);
  if (static_cast<double>(request.count) * smallest_volume / region_volume >
      kMaxRandomFillSolidFraction) {
    refuse_too_dense("count " + std::to_string(request.count) +
                         " even at the smallest possible radius: solid fraction",
                     static_cast<double>(request.count) * smallest_volume / region_volume);
  }
}

/// The radii of a fill, drawn first (so the target is reached by construction) and sorted
/// largest first; @p drawn_volume receives their volume. Refuses fills past
/// kMaxRandomFillSolidFraction, stopping the draw as soon as that is certain.
std::vector<double> draw_fill_radii(const FillRequest& request, Rng& rng, double& drawn_volume) {
  const Box& region = request.region;
  const double half_room = 0.5 * smallest_extent(region);
  const double region_volume = region.volume();
  // Radii first: the target is reached by construction, and sorting them is possible.
  std::vector<double> radii;
  drawn_volume = 0.0;
  const double target_volume = request.solid_fraction * region_volume;
  while (request.count > 0 ? radii.size() < request.count : drawn_volume < target_volume) {
    const double r = draw_radius(request.radius, rng);
    if (r > half_room) {
      throw std::invalid_argument("random fill: drawn radius " + std::to_string(r) +
                                  " does not fit the region " + box_text(region) +
                                  "; set a max cut-off on the radius distribution");
    }
    radii.push_back(r);
    drawn_volume += sphere_volume(r);
    // Past the limit the fill is refused below whatever is drawn next: stop drawing now.
    if (request.count > 0 && drawn_volume / region_volume > kMaxRandomFillSolidFraction) break;
  }
  if (drawn_volume / region_volume > kMaxRandomFillSolidFraction) {
    const std::string drawn = radii.size() < request.count
                                  ? "the first " + std::to_string(radii.size()) + " of " +
                                        std::to_string(request.count) + " drawn particles have"
                                  : "the " + std::to_string(radii.size()) + " drawn particles have";
    refuse_too_dense(drawn + " solid fraction", drawn_volume / region_volume);
  }
  // Ties are equal values, so the sorted sequence does not depend on the sort algorithm.
  std::sort(radii.begin(), radii.end(), std::greater<>());
  return radii;
}

/// Where a fill looks for overlaps: `near` holds spheres by their centre, `big` the existing
/// spheres too large for the 27 cells around a centre, in every cell they can reach.
struct FillGrids {
  std::array<std::size_t, 3> cells;
  CellGrid near;
  CellGrid big;
};

/// The grids of a fill of @p new_count spheres up to @p r_max, holding the existing spheres that
/// could touch one of them.
FillGrids index_existing(const Box& region, const ParticleList& existing, double r_max,
                         std::size_t new_count) {
  // Existing spheres that could touch a new one: center closer to the region than r + r_max.
  std::vector<Sphere> spheres;  // existing ones only; placed ones live in the grid
  for (const ParticleSpec& p : existing) {
    const Eigen::Vector3d gap =
        (region.min - p.position).cwiseMax(p.position - region.max).cwiseMax(0.0);
    const double reach = p.radius + r_max;
    if (gap.squaredNorm() < reach * reach) {
      spheres.push_back({p.position.x(), p.position.y(), p.position.z(), p.radius});
    }
  }
  const std::size_t n_existing = spheres.size();

  // `near` holds spheres by their center: with cell edges >= r + r_j, any overlapping sphere is
  // in the 27 cells around the new center. Existing spheres too big for that go to `big`, in
  // every cell their center +- (r_j + r_max) touches, so only the new center's cell is looked up.
  const double max_cells = 2.0 * static_cast<double>(n_existing + new_count) + 64.0;
  const auto cells = grid_cells(region, 2.0 * r_max, max_cells);
  FillGrids grids{cells, CellGrid(region, cells), CellGrid(region, cells)};
  CellGrid& near = grids.near;
  CellGrid& big = grids.big;
  const double near_limit = near.min_cell_size() - r_max;  // r_j up to this fit the 27 cells
  near.reserve(n_existing + new_count);
  for (const Sphere& e : spheres) {
    if (e.r <= near_limit) {
      near.add(near.coordinate(0, e.x), near.coordinate(1, e.y), near.coordinate(2, e.z), e);
      continue;
    }
    const double reach = e.r + r_max;
    const double c[3] = {e.x, e.y, e.z};
    std::array<std::size_t, 3> lo{}, hi{};
    for (int a = 0; a < 3; ++a) {
      lo[static_cast<std::size_t>(a)] = big.coordinate(a, c[a] - reach);
      hi[static_cast<std::size_t>(a)] = big.coordinate(a, c[a] + reach);
    }
    for (std::size_t z = lo[2]; z <= hi[2]; ++z) {
      for (std::size_t y = lo[1]; y <= hi[1]; ++y) {
        for (std::size_t x = lo[0]; x <= hi[0]; ++x) big.add(x, y, z, e);
      }
    }
  }

  return grids;
}

std::vector<ParticleSpec> insert_random_fill(const FillRequest& request,
                                             const ParticleList& existing) {
  validate_fill(request);
  const Box& region = request.region;
  const double region_volume = region.volume();
  Rng rng(request.seed);
  double drawn_volume = 0.0;
  const std::vector<double> radii = draw_fill_radii(request, rng, drawn_volume);
  const double r_max = radii.front();
  FillGrids grids = index_existing(region, existing, r_max, radii.size());
  CellGrid& near = grids.near;
  const CellGrid& big = grids.big;
  const std::array<std::size_t, 3>& cells = grids.cells;

  std::vector<ParticleSpec> out;
  out.reserve(radii.size());
  double placed_volume = 0.0;
  for (const double r : radii) {
    bool placed = false;
    for (std::size_t attempt = 0; attempt < request.max_attempts_per_particle; ++attempt) {
      Sphere s{0.0, 0.0, 0.0, r};
      double* const coordinates[3] = {&s.x, &s.y, &s.z};
      for (int a = 0; a < 3; ++a) {
        const double lo = region.min[a] + r;
        const double hi = region.max[a] - r;
        *coordinates[a] = std::clamp(lo + uniform01(rng) * (hi - lo), lo, hi);
      }
      const auto overlaps = [&s](const Sphere& o) {
        const double dx = o.x - s.x, dy = o.y - s.y, dz = o.z - s.z;
        const double reach = o.r + s.r;
        return dx * dx + dy * dy + dz * dz < reach * reach;
      };
      const std::size_t cx = near.coordinate(0, s.x);
      const std::size_t cy = near.coordinate(1, s.y);
      const std::size_t cz = near.coordinate(2, s.z);
      bool blocked = big.any_in_cell(cx, cy, cz, overlaps);
      for (std::size_t z = cz > 0 ? cz - 1 : 0; !blocked && z <= std::min(cz + 1, cells[2] - 1);
           ++z) {
        for (std::size_t y = cy > 0 ? cy - 1 : 0; !blocked && y <= std::min(cy + 1, cells[1] - 1);
             ++y) {
          for (std::size_t x = cx > 0 ? cx - 1 : 0; !blocked && x <= std::min(cx + 1, cells[0] - 1);
               ++x) {
            blocked = near.any_in_cell(x, y, z, overlaps);
          }
        }
      }
      if (blocked) continue;
      near.add(cx, cy, cz, s);
      ParticleSpec p;
      p.material = request.material;
      p.radius = r;
      p.position = Eigen::Vector3d(s.x, s.y, s.z);
      p.velocity = request.velocity;
      out.push_back(p);
      placed_volume += sphere_volume(r);
      placed = true;
      break;
    }
    if (!placed) {
      std::ostringstream m;
      m << "random fill: placed " << out.size() << " of " << radii.size() << " particles";
      if (request.count == 0) m << " (target solid fraction " << request.solid_fraction << ")";
      m << ", reached solid fraction " << fraction_text(placed_volume / region_volume) << " of "
        << fraction_text(drawn_volume / region_volume) << "; a particle of radius " << r
        << " found no free position in " << request.max_attempts_per_particle
        << " attempts. Random sequential addition jams near 0.30-0.38 solid fraction (lower "
           "with walls or existing particles): lower the target, raise "
           "max_attempts_per_particle, or pour and settle under gravity";
      throw InsertionError(m.str());
    }
  }
  return out;
}

namespace {

/// Particle specs binned in cells of edge >= 2 r_max, so that every partner of a particle lies in
/// the 27 cells around it; periodic axes span the domain.
struct SpecGrid {
  std::array<bool, 3> periodic{false, false, false};
  Eigen::Vector3d period = Eigen::Vector3d::Zero();  ///< domain length on periodic axes
  std::array<std::size_t, 3> cells{};
  std::vector<std::size_t> cell_of;  ///< cell of each particle
  std::vector<std::size_t> begin;    ///< size cells + 1
  std::vector<std::size_t> items;    ///< particles by cell, in index order within a cell

  /// Cell coordinates of particle @p i.
  std::array<std::size_t, 3> home(std::size_t i) const {
    return {cell_of[i] % cells[0], cell_of[i] / cells[0] % cells[1],
            cell_of[i] / (cells[0] * cells[1])};
  }
};

/// Bin @p particles (count -> scan -> fill); coordinates are clamped into the grid, which keeps
/// the 27-cell property true for any particle.
SpecGrid bin_specs(const ParticleList& particles, const Domain* domain) {
  const std::size_t n = particles.size();
  SpecGrid grid;
  double r_max = 0.0;
  Eigen::Vector3d lo = particles.front().position, hi = lo;
  for (const ParticleSpec& p : particles) {
    r_max = std::max(r_max, p.radius);
    lo = lo.cwiseMin(p.position);
    hi = hi.cwiseMax(p.position);
  }
  if (domain != nullptr) {
    grid.periodic = domain->periodic;
    for (int a = 0; a < 3; ++a) {
      if (!grid.periodic[a]) continue;
      lo[a] = domain->min[a];
      hi[a] = domain->max[a];
      grid.period[a] = domain->max[a] - domain->min[a];
    }
  }
  const Box bounds{lo, lo + (hi - lo).cwiseMax(Eigen::Vector3d::Constant(2.0 * r_max))};
  grid.cells = grid_cells(bounds, 2.0 * r_max, static_cast<double>(n) + 64.0);
  std::array<double, 3> width{};
  for (int a = 0; a < 3; ++a) {
    width[a] = (bounds.max[a] - bounds.min[a]) / static_cast<double>(grid.cells[a]);
  }
  const auto cell_coordinate = [&](int a, double v) -> std::size_t {
    const double c = std::floor((v - bounds.min[a]) / width[a]);
    if (!(c > 0.0)) return 0;
    return static_cast<std::size_t>(std::min(c, static_cast<double>(grid.cells[a] - 1)));
  };
  grid.cell_of.assign(n, 0);
  grid.begin.assign(grid.cells[0] * grid.cells[1] * grid.cells[2] + 1, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d x = particles[i].position;
    grid.cell_of[i] =
        (cell_coordinate(2, x.z()) * grid.cells[1] + cell_coordinate(1, x.y())) * grid.cells[0] +
        cell_coordinate(0, x.x());
    ++grid.begin[grid.cell_of[i] + 1];
  }
  for (std::size_t c = 1; c < grid.begin.size(); ++c) grid.begin[c] += grid.begin[c - 1];
  grid.items.assign(n, 0);
  std::vector<std::size_t> cursor(grid.begin.begin(), grid.begin.end() - 1);
  for (std::size_t i = 0; i < n; ++i) grid.items[cursor[grid.cell_of[i]]++] = i;
  return grid;
}

/// Cells to visit per axis around @p home: the neighbors, wrapped on periodic axes, each once (at
/// most 3 per axis, their number in @p visits).
void neighbor_cells(const SpecGrid& grid, const std::array<std::size_t, 3>& home,
                    std::array<std::array<std::size_t, 3>, 3>& visit,
                    std::array<std::size_t, 3>& visits) {
  visits = {0, 0, 0};
  for (std::size_t a = 0; a < 3; ++a) {
    const std::size_t count = grid.cells[a];
    for (int offset = -1; offset <= 1; ++offset) {
      const auto c = static_cast<long long>(home[a]) + offset;
      std::size_t cell = 0;
      if (c >= 0 && c < static_cast<long long>(count)) {
        cell = static_cast<std::size_t>(c);
      } else if (grid.periodic[a]) {
        cell = c < 0 ? count - 1 : 0;
      } else {
        continue;
      }
      const auto listed = visit[a].begin() + static_cast<std::ptrdiff_t>(visits[a]);
      if (std::find(visit[a].begin(), listed, cell) == listed) visit[a][visits[a]++] = cell;
    }
  }
}

/// The overlap of particle @p i with an earlier particle deeper than @p max_fraction of the
/// smaller radius, with the smallest earlier index, or none.
std::optional<InitialOverlap> overlap_with_earlier(const ParticleList& particles,
                                                   const SpecGrid& grid, std::size_t i,
                                                   double max_fraction) {
  const ParticleSpec p = particles[i];
  std::array<std::array<std::size_t, 3>, 3> visit{};
  std::array<std::size_t, 3> visits{};
  neighbor_cells(grid, grid.home(i), visit, visits);
  std::optional<InitialOverlap> found;
  for (std::size_t vz = 0; vz < visits[2]; ++vz) {
    for (std::size_t vy = 0; vy < visits[1]; ++vy) {
      for (std::size_t vx = 0; vx < visits[0]; ++vx) {
        const std::size_t cell =
            (visit[2][vz] * grid.cells[1] + visit[1][vy]) * grid.cells[0] + visit[0][vx];
        for (std::size_t k = grid.begin[cell]; k < grid.begin[cell + 1]; ++k) {
          const std::size_t j = grid.items[k];
          if (j >= i) break;  // index order within a cell: only earlier particles
          if (found && j >= found->earlier) break;
          const ParticleSpec q = particles[j];
          Eigen::Vector3d d = q.position - p.position;
          bool wrapped = false;
          for (int a = 0; a < 3; ++a) {
            // Well inside half a period the image is the particle itself: the shift below would
            // be a rounded zero, skipped with its division.
            if (!grid.periodic[a] || std::abs(d[a]) < 0.25 * grid.period[a]) continue;
            const double shift = grid.period[a] * std::round(d[a] / grid.period[a]);
            wrapped = wrapped || shift != 0.0;
            d[a] -= shift;
          }
          const double smaller = std::min(p.radius, q.radius);
          const double overlap = p.radius + q.radius - d.norm();
          if (overlap > max_fraction * smaller) {
            found = InitialOverlap{i, j, overlap / smaller, wrapped};
            break;
          }
        }
      }
    }
  }
  return found;
}

/// find_initial_overlap() of a list that is one lattice block, without a grid: the nearest
/// spheres are the neighbours one spacing apart and, along a periodic axis, the first sphere of a
/// row and the image of its last.
std::optional<InitialOverlap> lattice_overlap(const LatticeBlock& block, const Domain* domain,
                                              double max_fraction) {
  const double limit = max_fraction * block.radius;
  std::optional<InitialOverlap> found;
  const auto consider = [&](std::size_t later, std::size_t earlier, double distance, bool wrapped) {
    const double overlap = 2.0 * block.radius - distance;
    if (!(overlap > limit)) return;
    if (!found || later < found->later || (later == found->later && earlier < found->earlier)) {
      found = InitialOverlap{later, earlier, overlap / block.radius, wrapped};
    }
  };
  const std::size_t stride[3] = {1, block.counts[0], block.counts[0] * block.counts[1]};
  for (int a = 0; a < 3; ++a) {
    if (block.counts[a] > 1) consider(stride[a], 0, block.spacing, false);
    if (domain == nullptr || !domain->periodic[a]) continue;
    const double period = domain->max[a] - domain->min[a];
    const double span = block.last_centre()[a] - block.origin[a];
    if (block.counts[a] > 1) consider((block.counts[a] - 1) * stride[a], 0, period - span, true);
  }
  return found;
}

}  // namespace

std::optional<InitialOverlap> find_initial_overlap(const ParticleList& particles,
                                                   const Domain* domain, double max_fraction) {
  const std::size_t n = particles.size();
  if (n < 2) return std::nullopt;
  if (particles.stored_count() == 0) {
    const std::vector<LatticeBlock> blocks = particles.lattice_blocks();
    if (blocks.size() == 1) return lattice_overlap(blocks.front(), domain, max_fraction);
  }
  const SpecGrid grid = bin_specs(particles, domain);
  // In chunks of particles on every thread: the first chunk with an overlap holds the answer, and
  // every chunk before it is searched whole, so it is the serial one for any thread count (a
  // chunk after one known to have an overlap is skipped).
  constexpr std::size_t kChunk = 4096;
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<std::optional<InitialOverlap>> found(chunks);
  std::atomic<std::size_t> first_found{chunks};
#pragma omp parallel for schedule(dynamic) if (n >= kMinParallelParticles)
  for (std::size_t chunk = 0; chunk < chunks; ++chunk) {
    if (chunk > first_found.load(std::memory_order_relaxed)) continue;
    for (std::size_t i = chunk * kChunk; i < std::min(n, (chunk + 1) * kChunk); ++i) {
      found[chunk] = overlap_with_earlier(particles, grid, i, max_fraction);
      if (!found[chunk]) continue;
      std::size_t known = first_found.load(std::memory_order_relaxed);
      while (chunk < known && !first_found.compare_exchange_weak(known, chunk)) {
      }
      break;
    }
  }
  for (const std::optional<InitialOverlap>& overlap : found) {
    if (overlap) return overlap;
  }
  return std::nullopt;
}

}  // namespace bondem
