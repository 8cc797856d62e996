#pragma once
/// @file radius_distribution.hpp
/// The radius distribution of inserted particles: what an insertion at the start (insertion.hpp)
/// or during the run (a particle stream, case.hpp) draws its radii from.

namespace bondem {

/// Radius distribution of inserted particles; radii outside the cut-offs are redrawn.
///
/// - kConstant: `value`; no cut-offs.
/// - kUniform: r in [`min`, `max`); the bounds are the cut-offs.
/// - kNormal: `mean`, `std_dev` of r; cut-offs `min` and `max` (0 = none); r <= 0 is always
///   redrawn, since a radius must be positive.
/// - kLogNormal: ln r is normal with mean ln(`median`) and standard deviation `sigma`
///   (dimensionless), i.e. parameters of ln r, not of r, as sieve data are reported; cut-offs
///   `min` and `max` (0 = none).
///
/// Redrawing truncates the distribution, so the mean of a cut distribution differs from `mean`.
/// Normal and log-normal draws call std::log, std::cos and std::exp: bit-identical wherever the
/// same math library is used (e.g. glibc), but another libm may differ in the last bit.
struct RadiusDistribution {
  enum class Kind { kConstant, kUniform, kNormal, kLogNormal };
  Kind kind = Kind::kConstant;
  double value = 0.0;    ///< kConstant: the radius [m]
  double min = 0.0;      ///< kUniform: lower bound; kNormal/kLogNormal: lower cut-off, 0 = none [m]
  double max = 0.0;      ///< kUniform: upper bound; kNormal/kLogNormal: upper cut-off, 0 = none [m]
  double mean = 0.0;     ///< kNormal: mean radius before cut-offs [m]
  double std_dev = 0.0;  ///< kNormal: standard deviation of the radius before cut-offs [m]
  double median = 0.0;   ///< kLogNormal: median radius before cut-offs, exp(mu) [m]
  double sigma = 0.0;    ///< kLogNormal: standard deviation of ln r [-]
};

/// The largest radius @p distribution can give: its value, its upper bound or its upper cut-off
/// (0 when a normal or log-normal distribution has none).
inline double largest_radius(const RadiusDistribution& distribution) {
  return distribution.kind == RadiusDistribution::Kind::kConstant ? distribution.value
                                                                  : distribution.max;
}

/// The smallest radius @p distribution can give: its value, its lower bound or its lower cut-off
/// (0 when a normal or log-normal distribution has none).
inline double smallest_radius(const RadiusDistribution& distribution) {
  return distribution.kind == RadiusDistribution::Kind::kConstant ? distribution.value
                                                                  : distribution.min;
}

}  // namespace bondem
