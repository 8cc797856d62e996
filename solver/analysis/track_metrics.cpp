#include "solver/analysis/track_metrics.hpp"

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace bondem {

double distance_to_path(const Laser& laser, double x, double y) {
  const Eigen::Vector2d point(x, y);
  double nearest = std::numeric_limits<double>::infinity();
  for (const LaserSegment& segment : laser.path) {
    const Eigen::Vector2d along = segment.end - segment.start;
    const double length_sq = along.squaredNorm();
    const double t = length_sq > 0.0
                         ? std::clamp((point - segment.start).dot(along) / length_sq, 0.0, 1.0)
                         : 0.0;
    nearest = std::min(nearest, (point - (segment.start + t * along)).norm());
  }
  return nearest;
}

TrackReport measure_track(const Particles& p, const Laser& laser, double threshold) {
  TrackReport report;
  std::vector<double> reach;
  double distance_sum = 0.0;
  for (std::size_t i = 0; i < p.peak_temperature.size(); ++i) {
    report.peak_temperature = std::max(report.peak_temperature, p.peak_temperature[i]);
    if (p.peak_temperature[i] < threshold) continue;
    const double distance = distance_to_path(laser, p.x[i], p.y[i]);
    reach.push_back(distance + p.radius[i]);
    distance_sum += distance;
  }
  report.heated = reach.size();
  if (reach.empty()) return report;
  std::sort(reach.begin(), reach.end());
  const auto rank = static_cast<std::size_t>(std::ceil(0.95 * static_cast<double>(reach.size())));
  report.width = 2.0 * reach[std::max<std::size_t>(rank, 1) - 1];
  report.mean_heated_distance = distance_sum / static_cast<double>(reach.size());
  return report;
}

}  // namespace bondem
