#include "solver/driver/run_analysis.hpp"

#include <algorithm>
#include <cstdint>
#include <utility>

namespace bondem {

std::vector<int> bond_counts(const Particles& p, const Stepper& stepper) {
  std::vector<int> counts(p.size(), 0);
  const NeighborList& list = stepper.neighbors();
  list.for_each_pair([&](std::size_t i, std::size_t j, std::uint32_t k) {
    if (stepper.pair_forces().bonded[k] == 0) return;
    ++counts[i];
    ++counts[j];
  });
  return counts;
}

std::vector<std::pair<std::uint32_t, std::uint32_t>> bonded_pairs(const Stepper& stepper) {
  std::vector<std::pair<std::uint32_t, std::uint32_t>> bonded;
  stepper.neighbors().for_each_pair([&](std::size_t i, std::size_t j, std::uint32_t k) {
    if (stepper.pair_forces().bonded[k] != 0) {
      bonded.emplace_back(static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(j));
    }
  });
  return bonded;
}

namespace {

/// Solid fraction and coordination in the case's region, or in the bed below its surface.
void measure_packing(const Case& description, const AnalysedState& state, RunFigures& figures) {
  const Particles& p = state.particles;
  double max_radius = 0.0;
  for (const double r : p.radius) max_radius = std::max(max_radius, r);
  figures.packing_region =
      description.analysis_region
          ? *description.analysis_region
          : bed_region(p, Box{state.domain.min, state.domain.max}, 4.0 * max_radius);
  figures.packing = analyse_packing(p, state.contacts, figures.packing_region, state.domain);
}

/// Clusters: bonded agglomerates of two or more particles, and their size distribution against
/// the primary particles'. Particles with no bond are counted apart, as unbonded. Only the
/// agglomerates are kept (a cluster per particle would stay in memory to the end of the run), and
/// without a bonded pair there are none: every particle is a singleton.
void measure_clusters(const Particles& p,
                      const std::vector<std::pair<std::uint32_t, std::uint32_t>>& bonded,
                      RunFigures& figures) {
  ClusterReport& agglomerates = figures.clusters;
  figures.unbonded = p.size();
  if (!bonded.empty()) {
    ClusterReport clusters = find_clusters(p, bonded);
    for (std::size_t k = 0; k < clusters.sizes.size(); ++k) {
      if (clusters.sizes[k] < 2) continue;
      figures.unbonded -= clusters.sizes[k];
      figures.largest_cluster = std::max(figures.largest_cluster, clusters.sizes[k]);
      agglomerates.sizes.push_back(clusters.sizes[k]);
      agglomerates.volume_equivalent_diameters.push_back(clusters.volume_equivalent_diameters[k]);
    }
  }
  figures.agglomerates = agglomerates.sizes.size();
  std::vector<double> primary;
  primary.reserve(p.size());
  for (const double r : p.radius) primary.push_back(2.0 * r);
  figures.primary_sizes = size_quantiles(std::move(primary));
  figures.cluster_sizes = size_quantiles(agglomerates.volume_equivalent_diameters);
}

/// Heat received and the heat-affected band: particles that reached the bonding temperature (or,
/// without that criterion, the hottest tenth of the temperature rise).
ThermalReport measure_heat(const Case& description, const AnalysedState& state,
                           std::size_t agglomerates) {
  const Particles& p = state.particles;
  ThermalReport thermal;
  thermal.laser_energy = state.laser_energy;
  thermal.laser_missed = state.laser_missed;
  thermal.final_max_temperature = *std::max_element(p.temperature.begin(), p.temperature.end());
  thermal.clusters_of_two_or_more = agglomerates;
  double threshold = description.contact.bond.temperature;
  if (description.contact.bond.criterion != BondCriterion::kTemperature) {
    const double initial = description.thermal->initial_temperature;
    double peak = initial;
    for (const double t : p.peak_temperature) peak = std::max(peak, t);
    threshold = initial + 0.9 * (peak - initial);
  }
  thermal.threshold = threshold;
  if (description.laser) {
    thermal.track = measure_track(p, *description.laser, threshold);
  } else {
    for (const double t : p.peak_temperature) {
      thermal.track.peak_temperature = std::max(thermal.track.peak_temperature, t);
    }
  }
  return thermal;
}

}  // namespace

bool some_pair_can_bond(const Scene& scene) {
  return std::any_of(
      scene.pair_table.begin(), scene.pair_table.end(),
      [](const PairCoefficients& c) { return c.criterion != BondCriterion::kNever; });
}

LayerSnapshot measure_series_layer(const LayerSeries& series, std::size_t index,
                                   const Simulation& simulation) {
  const Scene& scene = simulation.scene();
  const Particles& p = scene.particles;
  LayerSnapshot snapshot;
  snapshot.layer = static_cast<int>(index) + 1;
  snapshot.time = simulation.stepper().time();
  snapshot.region = series.region;
  snapshot.floor_z = series.region.substrate_z;
  if (series.platform >= 0) {
    snapshot.floor_z = level_top(scene.boundaries.at(static_cast<std::size_t>(series.platform)));
    // The nominal top of the layers below: one layer height per layer spread before.
    snapshot.region.substrate_z =
        snapshot.floor_z + static_cast<double>(index) * series.region.layer_height;
  }
  snapshot.metrics = measure_layer(p, snapshot.region);
  if (!some_pair_can_bond(scene)) return snapshot;

  // Agglomerates reaching into the layer: a cluster counts when one of its particles' centres
  // lies in the layer's box (bounds included).
  const LayerRegion& box = snapshot.region;
  const auto in_layer = [&](std::size_t i) {
    return p.x[i] >= box.x_min && p.x[i] <= box.x_max && p.y[i] >= box.y_min &&
           p.y[i] <= box.y_max && p.z[i] >= box.substrate_z &&
           p.z[i] <= box.substrate_z + box.layer_height;
  };
  std::size_t agglomerates = 0, largest = 0;
  const std::vector<std::pair<std::uint32_t, std::uint32_t>> bonded =
      bonded_pairs(simulation.stepper());
  if (!bonded.empty()) {
    const ClusterReport clusters = find_clusters(p, bonded);
    std::vector<char> reaches(clusters.sizes.size(), 0);
    for (std::size_t i = 0; i < p.size(); ++i) {
      if (in_layer(i)) reaches[static_cast<std::size_t>(clusters.cluster_of[i])] = 1;
    }
    for (std::size_t k = 0; k < clusters.sizes.size(); ++k) {
      if (reaches[k] == 0 || clusters.sizes[k] < 2) continue;
      ++agglomerates;
      largest = std::max(largest, clusters.sizes[k]);
    }
  }
  snapshot.agglomerates = agglomerates;
  snapshot.largest_agglomerate = largest;
  return snapshot;
}

RunFigures analyse_run(const Case& description, const AnalysedState& state) {
  const Particles& p = state.particles;
  RunFigures figures;
  measure_packing(description, state, figures);
  measure_clusters(p, state.bonded, figures);
  if (p.thermal()) figures.thermal = measure_heat(description, state, figures.agglomerates);
  if (description.layer) figures.layer = measure_layer(p, *description.layer);
  return figures;
}

RunFigures analyse_run(const Case& description, const Simulation& simulation) {
  const Scene& scene = simulation.scene();
  const Stepper& stepper = simulation.stepper();
  const std::vector<int> contacts = contact_counts(scene.particles, stepper.neighbors());
  const std::vector<std::pair<std::uint32_t, std::uint32_t>> bonded = bonded_pairs(stepper);
  return analyse_run(description, AnalysedState{scene.particles, scene.domain, contacts, bonded,
                                                stepper.laser_energy(), stepper.laser_missed()});
}

}  // namespace bondem
