#pragma once
/// @file case.hpp
/// The validated description of a simulation case, as read from a case file (io/case_file.hpp).

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "geometry/boundary.hpp"
#include "geometry/box.hpp"
#include "geometry/domain.hpp"
#include "solver/analysis/layer_metrics.hpp"
#include "solver/engine/laser.hpp"
#include "solver/engine/slip_record.hpp"
#include "solver/models/bond_law.hpp"
#include "solver/models/normal_laws.hpp"
#include "solver/models/pair.hpp"
#include "solver/setup/particle_list.hpp"
#include "solver/setup/radius_distribution.hpp"

namespace bondem {

/// Most steps a run may take: beyond, a mistyped time.end or time.step is far likelier than a
/// real intent (10^12 steps of even one particle would take days). The reader refuses more; the
/// run checks again for cases built in code.
inline constexpr double kMaxSteps = 1e12;

/// [m/s]. Speeds at or above it are refused: no powder process comes near it, and the Hertz
/// quantities of v^2 overflow beyond it.
inline constexpr double kSpeedOfLight = 299792458.0;

/// Elastic solid of a particle species.
struct Material {
  std::string name;
  double density = 0.0;         ///< rho [kg/m^3]
  double youngs_modulus = 0.0;  ///< E [Pa]
  double poisson_ratio = 0.0;   ///< nu [-]
  // Thermal properties, used when the case has a `thermal:` block.
  double specific_heat = 0.0;         ///< c_p [J/(kg K)]
  double thermal_conductivity = 0.0;  ///< k [W/(m K)]
  double emissivity = 0.0;            ///< grey-body emissivity [-], for radiation
};

/// Bond parameters of the case (`bond:` block).
struct BondModel {
  double alpha = 1.0;  ///< alpha_adh, 0 <= alpha < 3/2
  AdhesionInput input = AdhesionInput::kEquilibriumOverlap;
  double stiffness = 0.0;            ///< k_adh [N/m^alpha] when input == kStiffness
  double equilibrium_overlap = 0.0;  ///< delta_eq [m] when input == kEquilibriumOverlap
  double damping_ratio = 0.0;        ///< xi_bond
  BondCriterion criterion = BondCriterion::kAlways;
  double temperature = 0.0;  ///< bonding temperature [K] of criterion kTemperature
};

/// The contact sub-models of one pair of materials: the `contact:` and `bond:` defaults, or an
/// `interactions:` entry applied over them.
struct ContactModel {
  double damping_ratio = 0.0;  ///< xi_con of the contact damper (derived when restitution > 0)
  /// Coefficient of restitution e of a normal impact; when > 0 the damping ratio is derived from
  /// it by the normal law's relation (restitution.hpp), else damping_ratio is the input.
  double restitution = 0.0;
  double friction = 0.0;          ///< Coulomb sliding friction mu
  double rolling_friction = 0.0;  ///< rolling resistance mu_r (dimensionless, times r*)
  RollingModel rolling_model = RollingModel::kConstantTorque;
  double rolling_damping = 0.3;  ///< eta_r of the EPSD damper (Ai et al. 2011 use 0.3)
  CohesionModel cohesion = CohesionModel::kNone;
  /// sjkr: energy density k [J/m^3]; jkr: surface energy w [J/m^2], pull-off (3/2) pi w r*.
  double cohesion_energy = 0.0;
  BondModel bond;  ///< the paper's bond law between particles of this pair
};

/// An `interactions:` entry: the contact model of one unordered pair of materials.
struct Interaction {
  int first_material = 0;   ///< index into Case::materials
  int second_material = 0;  ///< index into Case::materials (may equal the first)
  ContactModel model;

  /// Whether the entry is for the unordered pair of materials (a, b).
  bool joins(int a, int b) const {
    return (first_material == a && second_material == b) ||
           (first_material == b && second_material == a);
  }
};

/// Lumped heat transfer (`thermal:` block): m c_p dT/dt = sum of the heat flows into a particle.
struct ThermalModel {
  double initial_temperature = 293.15;  ///< [K] of particles not given their own
  double ambient_temperature = 293.15;  ///< [K] of the gas and the surroundings
  double convection_coefficient = 0.0;  ///< h [W/(m^2 K)] from each particle's surface to ambient
  bool radiation = false;  ///< grey-body radiation to ambient with each material's emissivity
};

/// An `insert:` entry of type `stream`: particles added during the run at a rate, each where it
/// overlaps no particle (Stepper; solver/engine/particle_stream.hpp).
struct StreamInsertion {
  /// Where centres are drawn: every inserted sphere lies inside; an axis of zero extent (a face)
  /// puts the centres on that plane.
  Box region;
  int material = 0;  ///< index into Case::materials
  /// Bounded (constant, uniform, or normal and log-normal with both cut-offs), so that the
  /// neighbor grid and the time step can allow for the largest and the smallest particle.
  RadiusDistribution radius;
  double particle_rate = 0.0;  ///< particles per second; or
  double mass_rate = 0.0;      ///< kilograms per second (exactly one of the two is > 0)
  double start_time = 0.0;     ///< [s]
  double end_time = 0.0;       ///< [s]; insertion stops then (the reader defaults it to time.end)
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  ///< of every inserted particle
  double temperature = 293.15;                         ///< [K] of every inserted particle
  std::uint64_t seed = 1;                              ///< same seed, same particles, bit for bit
  std::size_t max_attempts = 100;  ///< random centres tried per particle and step
};

/// Layers measured during a run, one per time (`analysis.layers`): layer n (from 1) at times[n-1]
/// in the box of region from z = base to base + region.layer_height, where base is
/// region.substrate_z, or with a platform its top at that time plus (n - 1) layer heights (the
/// nominal top of the layers below, on a platform lowered by one layer height per layer).
struct LayerSeries {
  std::vector<double> times;  ///< increasing, > 0; those after time.end are not reached [s]
  LayerRegion region;         ///< footprint, layer height, bins, grid; substrate_z without platform
  /// Index into the case's boundaries (and the scene's, in the same order) of the one the bed
  /// stands on; -1: the fixed substrate_z.
  int platform = -1;
};

/// Everything a run needs, validated: the output of the case-file reader.
struct Case {
  std::string source;  ///< file the case came from, for messages
  std::vector<Material> materials;
  ContactModel contact;  ///< the contact model of every pair of materials not in interactions
  std::vector<Interaction> interactions;  ///< per-pair overrides, each pair at most once
  /// The normal-force law and its run-wide parameters (the same for every pair).
  NormalLawSpec normal_law = BondLawSpec{};
  double time_step = 0.0;  ///< [s]
  double end_time = 0.0;   ///< [s]
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();
  ParticleList particles;                ///< explicit ones first, then each insertion in order
  std::vector<StreamInsertion> streams;  ///< insertions during the run, in case-file order
  /// The pair state (springs, bonds) of an initial state taken from a checkpoint, by particle ids.
  std::vector<SlipRecord> initial_pairs;
  std::optional<Domain> domain;  ///< absent: the particles' bounding box, padded, not periodic
  /// Walls, container faces, tools and meshes, in the order of the case file's `walls:` list (a
  /// box container adds its faces in place).
  std::vector<Boundary> boundaries;
  double skin = 0.0;          ///< Verlet skin [m]; 0 picks 0.2 x the largest radius
  int reorder_interval = 20;  ///< neighbor-list builds between reorderings by cell (0: never)
  double max_overlap_fraction = 0.25;  ///< overlap / smaller radius that stops a run (blow-up)
  std::string output_directory = "output";
  double checkpoint_interval = 0.0;  ///< [s] between checkpoints; 0: only at the end
  double vtk_interval = 0.0;         ///< [s] between VTK frames; 0: no VTK output
  double history_interval = 0.0;     ///< [s] between history rows; 0 picks end / 100
  double state_interval = 0.0;       ///< [s] between state_<n>.csv snapshots; 0: none
  /// history.csv's columns, in this order after `time` (always first); empty: every column.
  std::vector<std::string> history_fields;
  std::string history_fields_origin;  ///< where history_fields was read, for its errors
  /// The particle arrays of the VTK frames; empty: every array.
  std::vector<std::string> vtk_fields;
  std::string vtk_fields_origin;        ///< where vtk_fields was read, for its errors
  std::optional<ThermalModel> thermal;  ///< absent: no temperatures are tracked
  std::optional<Laser> laser;           ///< a moving heat source (needs `thermal`)
  /// Region whose particle centres define the reported bed solid fraction and coordination.
  std::optional<Box> analysis_region;
  /// Spread layer to measure at the end (solid fraction profile, roughness, bare substrate).
  std::optional<LayerRegion> layer;
  /// Layers to measure during the run, one after each spread (`analysis.layers`).
  std::optional<LayerSeries> layers;
  /// Every value the case-file reader read, by dotted key ("materials.steel.density",
  /// "walls.0.motion.1.velocity.2"), as it resolved it (numbers in their shortest exact form),
  /// and "{}" for every mapping it entered: sorted, so it is a canonical text of the file. It
  /// enters the checkpoint's case fingerprint whole, so no key can be left out of it. Empty for
  /// cases built in code.
  std::map<std::string, std::string> settings;

  /// The contact model of material pair (a, b): its interactions entry, else the defaults.
  const ContactModel& contact_model(int a, int b) const;
  /// Every coefficient of material pair (a, b), derived once for the run.
  PairCoefficients pair_coefficients(int a, int b) const;
};

/// Largest radius of case @p c: of its initial particles and of what its streams can insert.
inline double largest_radius(const Case& c) {
  double largest = 0.0;
  for (const ParticleSpec& p : c.particles) largest = std::max(largest, p.radius);
  for (const StreamInsertion& s : c.streams) largest = std::max(largest, largest_radius(s.radius));
  return largest;
}

/// Smallest radius of case @p c: of its initial particles and of what its streams can insert
/// (infinity for a case with neither).
inline double smallest_radius(const Case& c) {
  double smallest = std::numeric_limits<double>::infinity();
  for (const ParticleSpec& p : c.particles) smallest = std::min(smallest, p.radius);
  for (const StreamInsertion& s : c.streams)
    smallest = std::min(smallest, smallest_radius(s.radius));
  return smallest;
}

/// Verlet skin of case @p c whose largest radius is @p max_radius: neighbors.skin, or by default
/// 0.2 of that radius.
inline double verlet_skin(const Case& c, double max_radius) {
  return c.skin > 0.0 ? c.skin : 0.2 * max_radius;
}

}  // namespace bondem
