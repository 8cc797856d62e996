#pragma once
/// @file run_analysis.hpp
/// What a finished run is measured for: packing, bonded clusters, the spread layer, heat.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <utility>
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

/// One layer of a LayerSeries, measured after its spread.
struct LayerSnapshot {
  int layer = 0;         ///< from 1
  double time = 0.0;     ///< [s]
  double floor_z = 0.0;  ///< the platform's top at that time, or the fixed substrate_z [m]
  LayerRegion region;    ///< the layer's box: its substrate_z is the layer's base
  LayerMetrics metrics;
  /// Agglomerates (two or more bonded particles) with a particle centre inside the layer's box,
  /// and the particles in the largest of them; absent when no pair of materials can bond.
  std::optional<std::size_t> agglomerates, largest_agglomerate;
};

/// Whether some pair of materials of @p scene has a bond criterion other than `never`.
bool some_pair_can_bond(const Scene& scene);

/// Layer @p index (0-based; the layer numbered index + 1) of @p series, measured in the state of
/// @p simulation.
LayerSnapshot measure_series_layer(const LayerSeries& series, std::size_t index,
                                   const Simulation& simulation);

/// Bonds per particle in the stepper's last force evaluation.
std::vector<int> bond_counts(const Particles& p, const Stepper& stepper);

/// What analyse_run() measures, without a stepper: what a distributed run gathers from its parts.
struct AnalysedState {
  const Particles& particles;  ///< id, position, radius and, in thermal runs, temperatures
  const Domain& domain;
  const std::vector<int>& contacts;  ///< per particle, the partners it overlaps
  /// The bonded pairs, by particle index.
  const std::vector<std::pair<std::uint32_t, std::uint32_t>>& bonded;
  double laser_energy = 0.0;  ///< absorbed by the particles so far [J]
  double laser_missed = 0.0;  ///< absorbable energy that fell on no particle so far [J]
};

/// The figures of @p state for @p description (its analysis region, layer, bond criterion, laser).
RunFigures analyse_run(const Case& description, const AnalysedState& state);

/// The figures of the state @p simulation reached.
RunFigures analyse_run(const Case& description, const Simulation& simulation);

/// Pairs of particle indices bonded in the stepper's last force evaluation.
std::vector<std::pair<std::uint32_t, std::uint32_t>> bonded_pairs(const Stepper& stepper);

/// Measures the run at its end (finish() only: an interrupted run has no figures).
class RunAnalysis : public Observer {
 public:
  explicit RunAnalysis(const Case& description) : description_(description) {}
  /// Never between steps: it reads at the end.
  bool reads_state(const Simulation& /*simulation*/, std::int64_t /*step*/) const override {
    return false;
  }
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
