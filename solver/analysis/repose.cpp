#include "solver/analysis/repose.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <vector>

namespace bondem {

ReposeAngle dynamic_repose_angle(std::span<const double> x, std::span<const double> y,
                                 std::span<const double> z, std::span<const double> radius,
                                 const Eigen::Vector3d& axis, const Eigen::Vector3d& drum_centre,
                                 double drum_radius, const ReposeBinning& binning) {
  if (y.size() != x.size() || z.size() != x.size() || radius.size() != x.size())
    throw std::invalid_argument("dynamic_repose_angle: x, y, z and radius differ in length");
  // A unit axis to 1e-9 and horizontal to 1e-9: the chord and the heights below then hold to the
  // same relative accuracy.
  if (!(std::abs(axis.norm() - 1.0) <= 1.0e-9) || !(std::abs(axis.z()) <= 1.0e-9))
    throw std::invalid_argument(
        "dynamic_repose_angle: the drum axis must be a horizontal unit vector");
  if (!(drum_radius > 0.0) || !std::isfinite(drum_radius))
    throw std::invalid_argument("dynamic_repose_angle: the drum radius must be positive");
  if (binning.bins < 1 || !(binning.central_fraction > 0.0 && binning.central_fraction <= 1.0))
    throw std::invalid_argument(
        "dynamic_repose_angle: needs at least 1 bin and a central fraction in (0, 1]");

  // The cross-section is spanned by the horizontal chord direction and e_z (the axis is
  // horizontal, so e_z lies in it).
  const Eigen::Vector3d chord = axis.cross(Eigen::Vector3d::UnitZ()).normalized();
  const double half_band = binning.central_fraction * drum_radius;
  const double bin_width = 2.0 * half_band / binning.bins;

  // Per bin the highest top and where along the chord it is.
  constexpr double kNone = -std::numeric_limits<double>::infinity();
  std::vector<double> top(static_cast<std::size_t>(binning.bins), kNone);
  std::vector<double> at(static_cast<std::size_t>(binning.bins), 0.0);
  for (std::size_t i = 0; i < x.size(); ++i) {
    const Eigen::Vector3d offset = Eigen::Vector3d(x[i], y[i], z[i]) - drum_centre;
    const double u = offset.dot(chord);
    const double height = offset.z();
    // Distance from the axis: the in-section components are u and the height.
    if (u * u + height * height > drum_radius * drum_radius) continue;
    if (!(u >= -half_band && u <= half_band)) continue;
    const int bin = std::min(binning.bins - 1, static_cast<int>((u + half_band) / bin_width));
    const auto b = static_cast<std::size_t>(bin);
    const double particle_top = height + radius[i];
    if (particle_top > top[b] || (particle_top == top[b] && u < at[b])) {
      top[b] = particle_top;
      at[b] = u;
    }
  }

  // Least squares h = a + slope u through the surface points, in centred form (no cancellation
  // of large sums).
  ReposeAngle result{std::numeric_limits<double>::quiet_NaN(),
                     std::numeric_limits<double>::quiet_NaN(), 0,
                     std::numeric_limits<double>::quiet_NaN()};
  double sum_u = 0.0;
  double sum_h = 0.0;
  for (std::size_t b = 0; b < top.size(); ++b) {
    if (top[b] == kNone) continue;
    ++result.bins_used;
    sum_u += at[b];
    sum_h += top[b];
  }
  if (result.bins_used < 3) return result;
  const double mean_u = sum_u / result.bins_used;
  const double mean_h = sum_h / result.bins_used;
  double s_uu = 0.0;
  double s_uh = 0.0;
  for (std::size_t b = 0; b < top.size(); ++b) {
    if (top[b] == kNone) continue;
    s_uu += (at[b] - mean_u) * (at[b] - mean_u);
    s_uh += (at[b] - mean_u) * (top[b] - mean_h);
  }
  result.slope = s_uh / s_uu;
  double s_rr = 0.0;
  for (std::size_t b = 0; b < top.size(); ++b) {
    if (top[b] == kNone) continue;
    const double r = top[b] - (mean_h + result.slope * (at[b] - mean_u));
    s_rr += r * r;
  }
  result.residual = std::sqrt(s_rr / result.bins_used);
  result.degrees = std::atan(std::abs(result.slope)) * 180.0 / std::numbers::pi;
  return result;
}

}  // namespace bondem
