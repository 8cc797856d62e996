#pragma once
/// @file stepper.hpp
/// Velocity-Verlet time stepping of a scene: neighbors -> forces -> integrate.

#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "solver/contact_kernel.hpp"
#include "solver/neighbor_list.hpp"
#include "solver/scene.hpp"

namespace bondem {

/// A run that left the physics: non-finite values or an overlap beyond the scene's limit.
class BlowUpError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A tangential spring of a pair, keyed by ids; the elongation is seen from the first particle.
struct SlipRecord {
  std::int64_t first_id, second_id;
  double sx, sy, sz;
};

/// Everything besides the particle arrays that a restarted stepper needs to continue bit for bit.
struct StepperState {
  double time = 0.0;
  std::int64_t step = 0;
  ContactSummary contacts;
  NeighborListState list;
  std::vector<SlipRecord> slips;  ///< tangential springs of the pairs in contact
  std::vector<double> bodies;     ///< centre and velocity (6 values) of every moving body
};

/// Advances a scene in time. Owns the neighbor list and per-pair force slots; the scene owns the
/// particles. OpenMP-parallel; the state after any number of steps is the same bytes for any
/// thread count.
class Stepper {
 public:
  /// Pair flag for BondCriterion::kPairFlag, called with the particles' stable ids.
  using PairFlag = std::function<bool(std::int64_t id_i, std::int64_t id_j)>;

  /// Prepare to step @p scene: builds the neighbor list and evaluates the initial forces.
  explicit Stepper(Scene& scene, PairFlag pair_flag = {});

  /// Continue from a saved state; the scene's particles (forces included) must be those saved
  /// with it.
  Stepper(Scene& scene, const StepperState& restored, PairFlag pair_flag = {});

  /// One velocity-Verlet step of scene.time_step. Throws BlowUpError, after completing the step,
  /// when a value is not finite or an overlap exceeds scene.max_overlap_fraction of a radius.
  void step();

  /// The state to checkpoint together with the particles.
  StepperState save_state() const;

  /// Simulated time [s].
  double time() const { return time_; }
  /// Steps taken.
  std::int64_t step_count() const { return step_count_; }
  /// Contacts seen by the last force evaluation.
  const ContactSummary& contacts() const { return contacts_; }
  /// The current neighbor list (for analysis and output).
  const NeighborList& neighbors() const { return list_; }
  /// Per-pair forces of the last evaluation, indexed like the neighbor list.
  const PairForces& pair_forces() const { return pair_forces_; }
  /// Tangential spring elongations, indexed like the neighbor list.
  const PairHistory& pair_history() const { return history_; }
  /// Load on each wall, then each moving body (minus the force it exerts on the particles), from
  /// the last force evaluation, summed in index order.
  std::vector<Eigen::Vector3d> wall_forces() const;
  /// Kinetic energy of translation, summed in index order [J].
  double kinetic_energy() const;
  /// Kinetic energy of rotation, summed in index order [J].
  double rotational_energy() const;

 private:
  void compute_forces();
  void kick_spin(double half_dt);
  std::vector<SlipRecord> collect_slips() const;
  void apply_slips(std::vector<SlipRecord> slips);
  std::string diagnose_blow_up(bool finite) const;
  template <bool kFriction, class Adhesion>
  ContactSummary dispatch_criterion(Adhesion adhesion);

  Scene& scene_;
  PairFlag pair_flag_;
  NeighborList list_;
  PairForces pair_forces_;
  PairHistory history_;
  std::vector<double> wall_forces_;  ///< per particle and wall, from the last evaluation
  ContactSummary contacts_;
  double time_ = 0.0;
  std::int64_t step_count_ = 0;
};

}  // namespace bondem
