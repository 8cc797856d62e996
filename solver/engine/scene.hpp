#pragma once
/// @file scene.hpp
/// The runtime scene built from a case: particle arrays, the material-pair table and body forces.

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "geometry/boundary.hpp"
#include "geometry/domain.hpp"
#include "solver/engine/particle_stream.hpp"
#include "solver/engine/particles.hpp"
#include "solver/models/normal_laws.hpp"
#include "solver/models/pair.hpp"
#include "solver/setup/case.hpp"

namespace bondem {

/// What the stepper advances: particles plus the constant model data their forces need.
struct Scene {
  Particles particles;
  int material_count = 0;
  std::vector<std::string> material_names;   ///< by material index, for the outputs
  std::vector<PairCoefficients> pair_table;  ///< material_count^2 entries, row-major
  NormalLawSpec normal_law;                  ///< the normal-force law and its run-wide parameters
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();
  double time_step = 0.0;
  Domain domain;                     ///< cell-grid bounds and periodic axes
  std::vector<Boundary> boundaries;  ///< walls, container faces, tools and meshes
  /// Per boundary: its first contact slot in Particles' per-wall arrays and its slot count (one
  /// for an analytic shape, kMeshContactSlots for a mesh).
  std::vector<int> first_slot, slot_count;
  double skin = 0.0;  ///< Verlet skin [m]
  /// How far beyond touching a contact can hold [m]: the largest JKR separation distance, 0
  /// without JKR. Neighbor lists and tool tests reach this much further.
  double contact_range = 0.0;
  int reorder_interval = 20;  ///< sort particles by cell every this many list builds (0: never)
  bool friction = false;      ///< tangential law, rolling resistance and rotation are on
  /// Whether some output reads each pair's force at the steps whose state it reads (VTK frames'
  /// contacts): the fused pass (fused_pass.hpp), which keeps none, is then not taken.
  bool pair_forces_read = true;
  double max_overlap_fraction = 0.25;  ///< overlap / smaller radius beyond which a run stops
  // Heat transfer (particles.thermal() tells whether it is on).
  double ambient_temperature = 0.0;     ///< [K]
  double convection_coefficient = 0.0;  ///< h [W/(m^2 K)]
  std::vector<double> emissivity;       ///< per material, 0 without radiation
  std::optional<Laser> laser;
  /// Insertions during the run, each with its material's data (Stepper inserts their particles).
  std::vector<ParticleStream> streams;
  /// Largest radius of any particle the run holds or its streams can insert [m].
  double largest_radius = 0.0;
  /// Pair state (springs, bonds) by particle ids that the stepper starts from
  /// (Case::initial_pairs); it takes them over and empties this.
  std::vector<SlipRecord> initial_pairs;

  /// Whether any material pair has rolling resistance (then pairs store a rolling torque).
  bool rolling() const {
    return friction &&
           std::any_of(pair_table.begin(), pair_table.end(),
                       [](const PairCoefficients& c) { return c.rolling_friction != 0.0; });
  }
  /// Whether any material pair bonds by criterion kPairFlag (a caller's per-pair decision).
  bool needs_pair_flag() const {
    return std::any_of(pair_table.begin(), pair_table.end(), [](const PairCoefficients& c) {
      return c.criterion == BondCriterion::kPairFlag;
    });
  }
  /// Coefficients of material pair (a, b).
  const PairCoefficients& pair(int a, int b) const {
    return pair_table[static_cast<std::size_t>(a * material_count + b)];
  }
};

/// The ids build_scene() gives the case's particles @p chosen (indices into its list), in the
/// order of @p chosen: an initial state's keep theirs, the others take the next free ones in list
/// order. One walk through the list; memory for the chosen ones only.
std::vector<std::int64_t> particle_ids(const Case& description,
                                       const std::vector<std::uint32_t>& chosen);
/// The id after the largest that build_scene() gives (a stream's first particle takes it).
std::int64_t next_particle_id(const Case& description);

/// Build the scene of a validated case; particle ids are particle_ids().
Scene build_scene(const Case& description);
/// The scene of @p description with only the particles of @p chosen (indices into its particle
/// list, in that order), each with the id it has in the whole scene; every other value (domain,
/// largest radius, skin, ...) derived from the whole case: a process's share of a decomposed run.
Scene build_scene(const Case& description, const std::vector<std::uint32_t>& chosen);

/// Whether some pair of @p table has cohesion or EPSD rolling: then Particles::contact_history
/// and PairHistory carry the JKR flags and EPSD springs, and the kernels compiled for that storage
/// evaluate those models (sJKR needs no history but is evaluated only there: a run without any of
/// them keeps the plain kernel).
bool needs_contact_history(const std::vector<PairCoefficients>& table);

/// Mass of a sphere of the given radius and density.
double sphere_mass(double radius, double density);

}  // namespace bondem
