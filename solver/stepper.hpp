#pragma once
/// @file stepper.hpp
/// Velocity-Verlet time stepping of a scene: neighbors -> forces -> integrate.

#include <cstdint>
#include <functional>
#include <vector>

#include "solver/contact_kernel.hpp"
#include "solver/neighbors.hpp"
#include "solver/scene.hpp"

namespace bondem {

/// Advances a scene in time. Owns the neighbor list; the scene owns the particles.
class Stepper {
 public:
  /// Pair flag for BondCriterion::kPairFlag, called with the particles' stable ids.
  using PairFlag = std::function<bool(std::int64_t id_i, std::int64_t id_j)>;

  /// Prepare to step @p scene; evaluates the initial forces.
  explicit Stepper(Scene& scene, PairFlag pair_flag = {});

  /// One velocity-Verlet step of scene.time_step.
  void step();

  /// Simulated time [s].
  double time() const { return time_; }
  /// Steps taken.
  std::int64_t step_count() const { return step_count_; }
  /// Contacts seen by the last force evaluation.
  const ContactSummary& contacts() const { return contacts_; }

 private:
  void compute_forces();
  template <class Adhesion>
  ContactSummary dispatch_criterion(Adhesion adhesion);

  Scene& scene_;
  PairFlag pair_flag_;
  std::vector<ContactPair> pairs_;
  ContactSummary contacts_;
  double time_ = 0.0;
  std::int64_t step_count_ = 0;
};

}  // namespace bondem
