#include "solver/analysis.hpp"

#include <algorithm>
#include <numbers>

namespace bondem {

PackingReport analyse_packing(const Particles& p, const NeighborList& list, const Box& region) {
  const std::size_t n = p.size();
  std::vector<int> contacts(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::uint32_t k = list.row_begin[i]; k < list.row_begin[i + 1]; ++k) {
      const std::size_t j = list.second[k];
      const Eigen::Vector3d& shift = list.shifts[list.image[k]];
      const Eigen::Vector3d d(p.x[j] - p.x[i] + shift.x(), p.y[j] - p.y[i] + shift.y(),
                              p.z[j] - p.z[i] + shift.z());
      if (d.norm() < p.radius[i] + p.radius[j]) {
        ++contacts[i];
        ++contacts[j];
      }
    }
  }
  PackingReport report;
  double volume = 0.0;
  double coordination = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!region.contains(Eigen::Vector3d(p.x[i], p.y[i], p.z[i]))) continue;
    ++report.particles;
    volume += 4.0 / 3.0 * std::numbers::pi * p.radius[i] * p.radius[i] * p.radius[i];
    coordination += contacts[i];
  }
  report.solid_fraction = volume / region.volume();
  report.mean_coordination =
      report.particles > 0 ? coordination / static_cast<double>(report.particles) : 0.0;
  return report;
}

Box bed_region(const Particles& p, const Box& box, double margin) {
  double top = box.min.z();
  for (std::size_t i = 0; i < p.size(); ++i) top = std::max(top, p.z[i] + p.radius[i]);
  Box region{box.min.array() + margin, box.max.array() - margin};
  region.max.z() = std::min(region.max.z(), top - margin);
  return region;
}

}  // namespace bondem
