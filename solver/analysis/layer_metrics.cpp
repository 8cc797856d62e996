#include "solver/analysis/layer_metrics.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <stdexcept>
#include <string>

namespace bondem {

namespace {

/// Particle indices sorted by id (index breaks ties): every floating-point sum runs in this order
/// so that results do not depend on how the arrays happen to be ordered.
std::vector<std::uint32_t> id_order(const Particles& p) {
  std::vector<std::uint32_t> order(p.size());
  std::iota(order.begin(), order.end(), std::uint32_t{0});
  std::sort(order.begin(), order.end(), [&p](std::uint32_t a, std::uint32_t b) {
    return p.id[a] != p.id[b] ? p.id[a] < p.id[b] : a < b;
  });
  return order;
}

double sphere_volume(double r) {
  return 4.0 / 3.0 * std::numbers::pi * r * r * r;
}

/// Gauss-Legendre rule on [0, 1]. 32 points integrate the smoothed cross-section areas to
/// rounding level (measured ~1e-15 of the sphere volume; 20 points leave 1e-11).
constexpr int kQuadraturePoints = 32;
struct Quadrature {
  std::array<double, kQuadraturePoints> node{}, weight{};
};

/// Nodes by Newton iteration on the Legendre polynomial, computed once.
const Quadrature& gauss_legendre() {
  static const Quadrature rule = [] {
    Quadrature q;
    constexpr int n = kQuadraturePoints;
    for (int i = 0; i < n; ++i) {
      double x = std::cos(std::numbers::pi * (i + 0.75) / (n + 0.5));
      double derivative = 1.0;
      for (int iteration = 0; iteration < 100; ++iteration) {
        double p0 = 1.0, p1 = x;
        for (int k = 2; k <= n; ++k) {
          const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
          p0 = p1;
          p1 = p2;
        }
        derivative = n * (x * p1 - p0) / (x * x - 1.0);
        const double step = p1 / derivative;
        x -= step;
        if (std::abs(step) < 1e-16) break;
      }
      const auto k = static_cast<std::size_t>(i);
      q.node[k] = 0.5 * (1.0 - x);
      q.weight[k] = 1.0 / ((1.0 - x * x) * derivative * derivative);  // 2/(...) halved for [0,1]
    }
    return q;
  }();
  return rule;
}

/// Primitive of the half chord sqrt(R^2 - x^2).
double half_chord_primitive(double x, double radius) {
  const double t = std::clamp(x / radius, -1.0, 1.0);
  return 0.5 *
         (x * std::sqrt(std::max(radius * radius - x * x, 0.0)) + radius * radius * std::asin(t));
}

/// Area of the disc of radius @p radius centred at the origin inside [a0, a1] x [b0, b1], in
/// closed form: the x range is split where the chord ends cross y = b0 or y = b1, and on each piece
/// the upper and lower bounds are each either a constant or the circle.
double disc_rectangle_area(double radius, double a0, double a1, double b0, double b1) {
  if (!(radius > 0.0)) return 0.0;
  const double lo = std::max(a0, -radius);
  const double hi = std::min(a1, radius);
  if (!(lo < hi) || !(b0 < b1) || b0 >= radius || b1 <= -radius) return 0.0;
  // Unused slots stay +inf and sort to the end.
  std::array<double, 6> cuts;
  cuts.fill(std::numeric_limits<double>::infinity());
  std::size_t count = 0;
  cuts[count++] = lo;
  for (const double b : {b0, b1}) {
    if (std::abs(b) >= radius) continue;
    const double s = std::sqrt(radius * radius - b * b);
    for (const double c : {-s, s}) {
      if (c > lo && c < hi) cuts[count++] = c;
    }
  }
  cuts[count++] = hi;
  std::sort(cuts.begin(), cuts.end());
  double area = 0.0;
  for (std::size_t k = 0; k + 1 < count; ++k) {
    const double u = cuts[k];
    const double v = cuts[k + 1];
    if (!(u < v)) continue;
    const double mid = 0.5 * (u + v);
    const double h = std::sqrt(radius * radius - mid * mid);
    if (std::min(b1, h) <= std::max(b0, -h)) continue;  // the piece lies outside the band
    const double chord = half_chord_primitive(v, radius) - half_chord_primitive(u, radius);
    const double upper = b1 < h ? b1 * (v - u) : chord;
    const double lower = b0 > -h ? b0 * (v - u) : -chord;
    area += upper - lower;
  }
  return area;
}

/// Bounds of a box relative to a point, per axis.
struct Slab {
  double lo, hi;
};

}  // namespace

double sphere_box_volume(double cx, double cy, double cz, double r, const Box& box) {
  if (!(r > 0.0)) return 0.0;
  const std::array<Slab, 3> s{Slab{box.min.x() - cx, box.max.x() - cx},
                              Slab{box.min.y() - cy, box.max.y() - cy},
                              Slab{box.min.z() - cz, box.max.z() - cz}};
  int cut_axes = 0;
  std::size_t cut_axis = 0;
  for (std::size_t a = 0; a < 3; ++a) {
    if (!(s[a].lo < s[a].hi) || s[a].lo >= r || s[a].hi <= -r) return 0.0;
    if (s[a].lo > -r || s[a].hi < r) {
      ++cut_axes;
      cut_axis = a;
    }
  }
  if (cut_axes == 0) return sphere_volume(r);
  if (cut_axes == 1) {
    // The sphere between two parallel planes: integral of pi (r^2 - t^2) dt, exact.
    const double t0 = std::max(s[cut_axis].lo, -r);
    const double t1 = std::min(s[cut_axis].hi, r);
    return std::numbers::pi * (r * r * (t1 - t0) - (t1 * t1 * t1 - t0 * t0 * t0) / 3.0);
  }
  // Integrate the section area A(z) (disc of radius sqrt(r^2 - z^2) clipped to the x-y
  // rectangle). A is analytic except where the section radius passes the distance to a rectangle
  // edge line or corner, where it has (z - z_k)^{3/2} kinks; split there, and on each piece
  // substitute z = u0 + (u1 - u0)(1 - cos(pi t))/2, which turns the kinks into analytic sin^3
  // terms so that Gauss-Legendre converges geometrically.
  const double t0 = std::max(s[2].lo, -r);
  const double t1 = std::min(s[2].hi, r);
  std::array<double, 18> cuts;
  cuts.fill(std::numeric_limits<double>::infinity());
  std::size_t count = 0;
  cuts[count++] = t0;
  const auto add_distance = [&](double d2) {
    if (d2 >= r * r) return;
    const double zeta = std::sqrt(r * r - d2);
    for (const double c : {-zeta, zeta}) {
      if (c > t0 && c < t1) cuts[count++] = c;
    }
  };
  for (const double d : {s[0].lo, s[0].hi, s[1].lo, s[1].hi}) add_distance(d * d);
  for (const double dx : {s[0].lo, s[0].hi}) {
    for (const double dy : {s[1].lo, s[1].hi}) add_distance(dx * dx + dy * dy);
  }
  cuts[count++] = t1;
  std::sort(cuts.begin(), cuts.end());
  const Quadrature& rule = gauss_legendre();
  double volume = 0.0;
  for (std::size_t k = 0; k + 1 < count; ++k) {
    const double u0 = cuts[k];
    const double length = cuts[k + 1] - u0;
    if (!(length > 0.0)) continue;
    double piece = 0.0;
    for (std::size_t q = 0; q < rule.node.size(); ++q) {
      const double angle = std::numbers::pi * rule.node[q];
      const double z = u0 + length * 0.5 * (1.0 - std::cos(angle));
      const double jacobian = length * 0.5 * std::numbers::pi * std::sin(angle);
      const double section = std::sqrt(std::max(r * r - z * z, 0.0));
      piece += rule.weight[q] * jacobian *
               disc_rectangle_area(section, s[0].lo, s[0].hi, s[1].lo, s[1].hi);
    }
    volume += piece;
  }
  return volume;
}

ClusterReport find_clusters(const Particles& p,
                            const std::vector<std::pair<std::uint32_t, std::uint32_t>>& bonded) {
  const std::size_t n = p.size();
  std::vector<std::size_t> parent(n);
  std::iota(parent.begin(), parent.end(), std::size_t{0});
  const auto find = [&parent](std::size_t i) {
    while (parent[i] != i) {
      parent[i] = parent[parent[i]];  // path halving keeps trees shallow
      i = parent[i];
    }
    return i;
  };
  for (const auto& [a, b] : bonded) {
    if (a >= n || b >= n) {
      throw std::out_of_range("find_clusters: bonded pair (" + std::to_string(a) + ", " +
                              std::to_string(b) +
                              ") names a particle index >= " + std::to_string(n));
    }
    const std::size_t ra = find(a);
    const std::size_t rb = find(b);
    // Which root wins does not matter: labels come from ids below.
    if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
  }

  ClusterReport report;
  report.cluster_of.assign(n, -1);
  std::vector<std::int64_t> label_of_root(n, -1);
  std::vector<double> cubed_radius_sum;
  // Visiting particles by increasing id meets each cluster first at its smallest id, so labels
  // come out in that order, and volumes are summed in an order independent of the arrays.
  for (const std::uint32_t i : id_order(p)) {
    const std::size_t root = find(i);
    if (label_of_root[root] < 0) {
      label_of_root[root] = static_cast<std::int64_t>(report.sizes.size());
      report.sizes.push_back(0);
      cubed_radius_sum.push_back(0.0);
    }
    const auto label = static_cast<std::size_t>(label_of_root[root]);
    report.cluster_of[i] = label_of_root[root];
    ++report.sizes[label];
    cubed_radius_sum[label] += p.radius[i] * p.radius[i] * p.radius[i];
  }
  report.volume_equivalent_diameters.reserve(cubed_radius_sum.size());
  for (const double sum : cubed_radius_sum) {
    report.volume_equivalent_diameters.push_back(2.0 * std::cbrt(sum));
  }
  return report;
}

SizeQuantiles size_quantiles(std::vector<double> diameters) {
  for (const double d : diameters) {
    if (!std::isfinite(d)) throw std::invalid_argument("size_quantiles: non-finite diameter");
  }
  SizeQuantiles q;
  q.count = diameters.size();
  if (diameters.empty()) return q;
  std::sort(diameters.begin(), diameters.end());
  const auto quantile = [&diameters](double level) {
    const double position = level * static_cast<double>(diameters.size() - 1);
    const auto k = static_cast<std::size_t>(std::floor(position));
    if (k + 1 >= diameters.size()) return diameters.back();
    const double fraction = position - static_cast<double>(k);
    return diameters[k] + fraction * (diameters[k + 1] - diameters[k]);
  };
  q.d10 = quantile(0.1);
  q.d50 = quantile(0.5);
  q.d90 = quantile(0.9);
  return q;
}

namespace {

void validate(const LayerRegion& region) {
  const auto fail = [](const std::string& what) {
    throw std::invalid_argument("measure_layer: " + what);
  };
  for (const double v : {region.x_min, region.x_max, region.y_min, region.y_max, region.substrate_z,
                         region.layer_height, region.grid_spacing}) {
    if (!std::isfinite(v)) fail("non-finite region bound");
  }
  if (!(region.x_max > region.x_min)) fail("x_max must exceed x_min");
  if (!(region.y_max > region.y_min)) fail("y_max must exceed y_min");
  if (!(region.layer_height > 0.0)) fail("layer_height must be positive");
  if (region.bins < 1) fail("bins must be at least 1");
  if (region.grid_spacing < 0.0) fail("grid_spacing must be >= 0");
}

/// Index of the interval of width @p width from @p origin holding @p v, clamped to [0, count).
std::size_t interval_of(double v, double origin, double width, std::size_t count) {
  const double k = std::floor((v - origin) / width);
  if (!(k > 0.0)) return 0;  // also catches NaN
  return std::min(static_cast<std::size_t>(std::min(k, 1e18)), count - 1);
}

/// Columns along a side of length @p length for a target spacing.
std::size_t column_count(double length, double spacing) {
  const double n = std::round(length / spacing);
  if (!(n <= kMaxLayerColumns)) throw std::invalid_argument("measure_layer: surface grid too fine");
  return std::max<std::size_t>(1, static_cast<std::size_t>(n));
}

}  // namespace

double layer_grid_columns(const LayerRegion& region, double spacing) {
  const auto side = [&](double length) { return std::max(1.0, std::round(length / spacing)); };
  return side(region.x_max - region.x_min) * side(region.y_max - region.y_min);
}

namespace {

/// The particles that can be the top of a column, copied contiguously for the column loop.
struct SurfaceCandidates {
  std::vector<double> x, y, z, r, r2;
  double r_min = std::numeric_limits<double>::infinity();
};

/// Particles with their centre at most 3 layer heights up, their top above the substrate and
/// their disc reaching into the footprint, in @p order.
SurfaceCandidates surface_candidates(const Particles& p, const LayerRegion& region,
                                     const std::vector<std::uint32_t>& order) {
  const double z_cut = region.substrate_z + 3.0 * region.layer_height;
  // Particles that can be the top of a column: centre at most 3 layer heights up, top above the
  // substrate, disc reaching into the footprint. Copied contiguously for the column loop.
  SurfaceCandidates c;
  for (const std::uint32_t i : order) {
    const double r = p.radius[i];
    if (!(r > 0.0) || p.z[i] > z_cut || p.z[i] + r <= region.substrate_z) continue;
    if (p.x[i] + r <= region.x_min || p.x[i] - r >= region.x_max) continue;
    if (p.y[i] + r <= region.y_min || p.y[i] - r >= region.y_max) continue;
    c.x.push_back(p.x[i]);
    c.y.push_back(p.y[i]);
    c.z.push_back(p.z[i]);
    c.r.push_back(r);
    c.r2.push_back(r * r);
    c.r_min = std::min(c.r_min, r);
  }
  return c;
}

/// Surface statistics of the column grid (nx by ny) over @p c: the columns covered, and the
/// mean, sum of squared deviations (Welford) and largest of their heights above the substrate.
struct SurfaceSums {
  std::size_t covered = 0;
  double mean = 0.0, m2 = 0.0, highest = 0.0;
};

/// Splats every candidate's disc onto the columns under it, one band of rows at a time.
SurfaceSums splat_heights(const SurfaceCandidates& c, const LayerRegion& region, std::size_t nx,
                          std::size_t ny) {
  const std::size_t n = c.x.size();
  const double lx = region.x_max - region.x_min;
  const double ly = region.y_max - region.y_min;
  // The height map is filled by splatting: each particle visits only the columns under its disc,
  // so the work is the sum of the discs' column counts (not columns times particles per cell).
  // To bound memory the map is held one band of rows at a time; particles are bucketed by the
  // bands their discs overlap (count -> scan -> fill). A column's top is a maximum, which does not
  // depend on the order of the particles.
  const double dx_col = lx / static_cast<double>(nx);
  const double dy_col = ly / static_cast<double>(ny);
  const std::size_t band_rows = std::clamp<std::size_t>((std::size_t{1} << 18) / nx, 1, ny);
  const std::size_t bands = (ny + band_rows - 1) / band_rows;
  // Rows (and below, columns) are bracketed from the disc's extent widened by one, and each
  // column is then tested exactly, so rounding in the bracket cannot drop a column.
  const auto row_range = [&](std::size_t k, std::size_t& first, std::size_t& last) {
    first = interval_of(c.y[k] - c.r[k], region.y_min, dy_col, ny);
    first = first > 0 ? first - 1 : 0;
    last = std::min(interval_of(c.y[k] + c.r[k], region.y_min, dy_col, ny) + 1, ny - 1);
  };
  std::vector<std::size_t> band_begin(bands + 1, 0);
  std::size_t first = 0, last = 0;
  for (std::size_t k = 0; k < n; ++k) {
    row_range(k, first, last);
    for (std::size_t b = first / band_rows; b <= last / band_rows; ++b) ++band_begin[b + 1];
  }
  std::partial_sum(band_begin.begin(), band_begin.end(), band_begin.begin());
  std::vector<std::uint32_t> items(band_begin[bands]);
  std::vector<std::size_t> fill(band_begin.begin(), band_begin.end() - 1);
  for (std::size_t k = 0; k < n; ++k) {
    row_range(k, first, last);
    for (std::size_t b = first / band_rows; b <= last / band_rows; ++b) {
      items[fill[b]++] = static_cast<std::uint32_t>(k);
    }
  }

  // Welford's update keeps mean and variance accurate in one pass without keeping the whole
  // height map; columns are visited in row-major order, so the result is deterministic.
  std::vector<double> top;  // height of each column of the band above the substrate; 0 = empty
  std::size_t covered = 0;
  double mean = 0.0, m2 = 0.0, highest = 0.0;
  for (std::size_t b = 0; b < bands; ++b) {
    const std::size_t row0 = b * band_rows;
    const std::size_t row1 = std::min(row0 + band_rows, ny);
    top.assign((row1 - row0) * nx, 0.0);
    for (std::size_t e = band_begin[b]; e < band_begin[b + 1]; ++e) {
      const std::uint32_t k = items[e];
      row_range(k, first, last);
      for (std::size_t jy = std::max(first, row0); jy <= std::min(last, row1 - 1); ++jy) {
        const double yc = region.y_min + (static_cast<double>(jy) + 0.5) * dy_col;
        const double ddy = yc - c.y[k];
        const double half_width_sq = c.r2[k] - ddy * ddy;
        if (half_width_sq < 0.0) continue;
        const double half_width = std::sqrt(half_width_sq);
        std::size_t ix0 = interval_of(c.x[k] - half_width, region.x_min, dx_col, nx);
        ix0 = ix0 > 0 ? ix0 - 1 : 0;
        const std::size_t ix1 =
            std::min(interval_of(c.x[k] + half_width, region.x_min, dx_col, nx) + 1, nx - 1);
        double* row = top.data() + (jy - row0) * nx;
        for (std::size_t ix = ix0; ix <= ix1; ++ix) {
          const double xc = region.x_min + (static_cast<double>(ix) + 0.5) * dx_col;
          const double ddx = xc - c.x[k];
          const double rest = c.r2[k] - ddx * ddx - ddy * ddy;  // the column centre is in the disc
          if (rest < 0.0) continue;
          // Heights at or below the substrate leave the column empty (the map starts at 0).
          row[ix] = std::max(row[ix], c.z[k] + std::sqrt(rest) - region.substrate_z);
        }
      }
    }
    for (const double h : top) {
      if (!(h > 0.0)) continue;
      ++covered;
      const double delta = h - mean;
      mean += delta / static_cast<double>(covered);
      m2 += delta * (h - mean);
      highest = std::max(highest, h);
    }
  }
  return {covered, mean, m2, highest};
}

/// Top-surface statistics over the column grid (fills the surface fields of @p m).
void measure_surface(const Particles& p, const LayerRegion& region,
                     const std::vector<std::uint32_t>& order, LayerMetrics& m) {
  const SurfaceCandidates c = surface_candidates(p, region, order);
  m.empty_fraction = 1.0;
  const double spacing = region.grid_spacing > 0.0 ? region.grid_spacing : 0.25 * c.r_min;
  if (!(spacing < std::numeric_limits<double>::infinity())) return;  // no spacing, no particle
  const double lx = region.x_max - region.x_min;
  const double ly = region.y_max - region.y_min;
  const std::size_t nx = column_count(lx, spacing);
  const std::size_t ny = column_count(ly, spacing);
  if (static_cast<double>(nx) * static_cast<double>(ny) > kMaxLayerColumns) {
    throw std::invalid_argument("measure_layer: surface grid too fine");
  }
  m.columns = nx * ny;
  if (c.x.empty()) return;

  const auto [covered, mean, m2, highest] = splat_heights(c, region, nx, ny);
  m.covered_columns = covered;
  m.empty_fraction = static_cast<double>(m.columns - covered) / static_cast<double>(m.columns);
  if (covered > 0) {
    m.mean_surface_height = mean;
    m.roughness = std::sqrt(std::max(m2, 0.0) / static_cast<double>(covered));
    m.max_surface_height = highest;
  }
}

}  // namespace

LayerMetrics measure_layer(const Particles& p, const LayerRegion& region) {
  validate(region);
  const std::vector<std::uint32_t> order = id_order(p);
  const auto bins = static_cast<std::size_t>(region.bins);
  const double lx = region.x_max - region.x_min;
  const double ly = region.y_max - region.y_min;
  const double z_top = region.substrate_z + region.layer_height;
  const double bin_width = lx / static_cast<double>(bins);
  // The last edge is x_max itself, so the slabs tile the box with no rounding gap.
  const auto edge = [&](std::size_t k) {
    return k == bins ? region.x_max : region.x_min + bin_width * static_cast<double>(k);
  };
  const Box layer{Eigen::Vector3d(region.x_min, region.y_min, region.substrate_z),
                  Eigen::Vector3d(region.x_max, region.y_max, z_top)};

  LayerMetrics m;
  std::vector<double> bin_volume(bins, 0.0);
  double volume = 0.0;
  for (const std::uint32_t i : order) {
    const double x = p.x[i], y = p.y[i], z = p.z[i], r = p.radius[i];
    if (x >= region.x_min && x <= region.x_max && y >= region.y_min && y <= region.y_max &&
        z >= region.substrate_z) {
      ++m.particles;
    }
    if (!(r > 0.0) || x + r <= region.x_min || x - r >= region.x_max || y + r <= region.y_min ||
        y - r >= region.y_max || z + r <= region.substrate_z || z - r >= z_top) {
      continue;
    }
    volume += sphere_box_volume(x, y, z, r, layer);
    const std::size_t k0 = interval_of(x - r, region.x_min, bin_width, bins);
    const std::size_t k1 = interval_of(x + r, region.x_min, bin_width, bins);
    for (std::size_t k = k0; k <= k1; ++k) {
      Box slab = layer;
      slab.min.x() = edge(k);
      slab.max.x() = edge(k + 1);
      bin_volume[k] += sphere_box_volume(x, y, z, r, slab);
    }
  }
  m.solid_fraction = volume / layer.volume();
  m.bin_x_center.resize(bins);
  m.bin_solid_fraction.resize(bins);
  for (std::size_t k = 0; k < bins; ++k) {
    m.bin_x_center[k] = 0.5 * (edge(k) + edge(k + 1));
    m.bin_solid_fraction[k] = bin_volume[k] / ((edge(k + 1) - edge(k)) * ly * region.layer_height);
  }
  measure_surface(p, region, order, m);
  return m;
}

}  // namespace bondem
