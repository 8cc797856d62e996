#pragma once
/// @file run_analysis.hpp
/// What a finished run is measured for: packing, bonded clusters, the spread layer, heat.

#include <cstddef>
#include <optional>
#include <vector>

#include "geometry/box.hpp"
#include "solver/analysis/layer_metrics.hpp"
#include "solver/analysis/packing.hpp"
#include "solver/analysis/track_metrics.hpp"
#include "solver/driver/simulation.hpp"
#include "solver/setup/case.hpp"

namespace bondem {

/// Heat and bonding of a thermal run.
struct ThermalReport {
  double laser_energy = 0.0;                ///< absorbed by the particles [J]
  double laser_missed = 0.0;                ///< absorbable energy that fell on no particle [J]
  double final_max_temperature = 0.0;       ///< [K]
  double threshold = 0.0;                   ///< temperature that defines the heat-affected band [K]
  TrackReport track;                        ///< band along the laser path, peak temperature
  std::size_t clusters_of_two_or_more = 0;  ///< bonded agglomerates at the end
};

/// The end-of-run figures of a run.
struct RunFigures {
  Box packing_region;     ///< the case's analysis.region, or the bed below its surface
  PackingReport packing;  ///< solid fraction and coordination in packing_region
  /// The agglomerates (clusters of two or more particles) in the order of find_clusters()'s
  /// labels; cluster_of is left empty.
  ClusterReport clusters;
  std::size_t agglomerates = 0;          ///< clusters of two or more particles
  std::size_t largest_cluster = 0;       ///< particles in the largest of them (0 if none)
  std::size_t unbonded = 0;              ///< particles with no bond (in no agglomerate)
  SizeQuantiles primary_sizes;           ///< particle diameters
  SizeQuantiles cluster_sizes;           ///< volume-equivalent diameters of the agglomerates
  std::optional<LayerMetrics> layer;     ///< spread layer, when the case asks for it
  std::optional<ThermalReport> thermal;  ///< thermal runs only
};

/// Bonds per particle in the stepper's last force evaluation.
std::vector<int> bond_counts(const Particles& p, const Stepper& stepper);

/// The figures of the state @p simulation reached, for @p description (its analysis region,
/// layer, bond criterion, laser).
RunFigures analyse_run(const Case& description, const Simulation& simulation);

/// Measures the run at its end (finish() only: an interrupted run has no figures).
class RunAnalysis : public Observer {
 public:
  explicit RunAnalysis(const Case& description) : description_(description) {}
  void finish(const Simulation& simulation) override {
    figures_ = analyse_run(description_, simulation);
  }
  /// The figures, once finish() was called.
  const std::optional<RunFigures>& figures() const { return figures_; }

 private:
  const Case& description_;
  std::optional<RunFigures> figures_;
};

}  // namespace bondem
