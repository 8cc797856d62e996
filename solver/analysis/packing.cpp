#include "solver/analysis/packing.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <numeric>
#include <sstream>
#include <vector>

#include "solver/analysis/layer_metrics.hpp"
#include "solver/engine/exact_sum.hpp"

namespace bondem {

namespace {

/// Why @p region is too small to measure, or "" if it is not.
std::string region_too_small(const Particles& p, const Box& region, std::size_t centred) {
  static constexpr const char* kAxis[3] = {"x", "y", "z"};
  std::ostringstream reason;
  for (int a = 0; a < 3; ++a) {
    if (!(region.max[a] > region.min[a]) || !std::isfinite(region.max[a] - region.min[a])) {
      reason << "the region is empty along " << kAxis[a] << ", from " << region.min[a] << " to "
             << region.max[a] << " m";
      return reason.str();
    }
  }
  if (p.size() == 0) return "no particles";
  const double mean_diameter =
      2.0 * std::accumulate(p.radius.begin(), p.radius.end(), 0.0) / static_cast<double>(p.size());
  for (int a = 0; a < 3; ++a) {
    const double diameters = (region.max[a] - region.min[a]) / mean_diameter;
    if (diameters < kMinRegionDiameters) {
      reason << "the region spans " << std::setprecision(3) << diameters
             << " mean particle diameters along " << kAxis[a] << ", fewer than "
             << kMinRegionDiameters;
      return reason.str();
    }
  }
  if (centred < kMinRegionParticles) {
    reason << "only " << centred << " particle centres in the region, fewer than "
           << kMinRegionParticles;
    return reason.str();
  }
  return "";
}

/// Volume of the sphere at @p centre inside @p region, its periodic images included.
double clipped_volume(const Eigen::Vector3d& centre, double r, const Box& region,
                      const Domain& domain) {
  const Eigen::Vector3d length = domain.length();
  // Most spheres of a bed lie inside the region. Such a sphere's images a period away then clear
  // the region by a diameter, far beyond rounding, where it is a diameter narrower than the
  // period (as a bed region within the walls is): the box test below skips them all, and its
  // volume is its own clipped volume, the loop's one term, the same bytes.
  bool inside = true;
  for (int a = 0; a < 3; ++a) {
    inside = inside && centre[a] - r > region.min[a] && centre[a] + r < region.max[a] &&
             (!domain.periodic[static_cast<std::size_t>(a)] ||
              region.max[a] - region.min[a] + 2.0 * r <= length[a]);
  }
  if (inside) return sphere_box_volume(centre.x(), centre.y(), centre.z(), r, region);
  double volume = 0.0;
  for (int sx = -1; sx <= 1; ++sx) {
    for (int sy = -1; sy <= 1; ++sy) {
      for (int sz = -1; sz <= 1; ++sz) {
        const int shift[3] = {sx, sy, sz};
        bool skip = false;
        Eigen::Vector3d c = centre;
        for (int a = 0; a < 3; ++a) {
          if (shift[a] != 0 && !domain.periodic[static_cast<std::size_t>(a)]) skip = true;
          c[a] += shift[a] * length[a];
          // The box test first: most spheres are far from the region or its images.
          if (c[a] + r <= region.min[a] || c[a] - r >= region.max[a]) skip = true;
        }
        if (!skip) volume += sphere_box_volume(c.x(), c.y(), c.z(), r, region);
      }
    }
  }
  return volume;
}

}  // namespace

std::vector<int> contact_counts(const Particles& p, const NeighborList& list) {
  std::vector<int> contacts(p.size(), 0);
  list.for_each_pair([&](std::size_t i, std::size_t j, std::uint32_t k) {
    if (list.separation(p, i, j, k).norm() < p.radius[i] + p.radius[j]) {
      ++contacts[i];
      ++contacts[j];
    }
  });
  return contacts;
}

PackingReport analyse_packing(const Particles& p, const NeighborList& list, const Box& region,
                              const Domain& domain) {
  return analyse_packing(p, contact_counts(p, list), region, domain);
}

PackingReport analyse_packing(const Particles& p, const std::vector<int>& contacts,
                              const Box& region, const Domain& domain) {
  // Totals that do not depend on how the particles are stored or on the thread count: an
  // integer count and an exact sum of the volumes, in any order.
  const std::size_t n = p.size();
  PackingReport report;
  std::size_t coordination = 0;
  std::size_t centred = 0;
#pragma omp parallel for schedule(static) if (n >= kMinParallelParticles) \
    reduction(+ : coordination, centred)
  for (std::size_t i = 0; i < n; ++i) {
    if (!region.contains(Eigen::Vector3d(p.x[i], p.y[i], p.z[i]))) continue;
    ++centred;
    coordination += static_cast<std::size_t>(contacts[i]);
  }
  report.particles = centred;
  report.unmeasured_reason = region_too_small(p, region, report.particles);
  if (!report.unmeasured_reason.empty()) return report;
  ExactSum volume;
#pragma omp parallel if (n >= kMinParallelParticles)
  {
    ExactSum part;
#pragma omp for schedule(static) nowait
    for (std::size_t i = 0; i < n; ++i) {
      part.add(
          clipped_volume(Eigen::Vector3d(p.x[i], p.y[i], p.z[i]), p.radius[i], region, domain));
    }
#pragma omp critical(bondem_packing_volume)
    volume += part;
  }
  report.solid_fraction = volume.value() / region.volume();
  report.mean_coordination =
      static_cast<double>(coordination) / static_cast<double>(report.particles);
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
