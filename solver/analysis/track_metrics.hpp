#pragma once
/// @file track_metrics.hpp
/// What a laser track did to a powder layer: which particles it heated past a temperature, how
/// wide that band is, and how hot it got.

#include <cstddef>

#include "solver/engine/laser.hpp"
#include "solver/engine/particles.hpp"

namespace bondem {

/// The heat-affected band along a laser path.
struct TrackReport {
  std::size_t heated = 0;         ///< particles whose peak temperature reached the threshold
  double width = 0.0;             ///< 2 x the 95th percentile of (distance to path + radius) [m]
  double peak_temperature = 0.0;  ///< highest temperature any particle reached [K]
  double mean_heated_distance = 0.0;  ///< mean horizontal distance of heated centres to the path
};

/// Horizontal distance from (x, y) to the laser's polyline path [m].
double distance_to_path(const Laser& laser, double x, double y);

/// Measure the band of particles whose p.peak_temperature reached @p threshold [K]. Using the 95th
/// percentile rather than the largest distance keeps one stray hot particle from setting the
/// width. Needs a thermal particle set.
TrackReport measure_track(const Particles& p, const Laser& laser, double threshold);

}  // namespace bondem
