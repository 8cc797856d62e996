#pragma once
/// @file collision.hpp
/// The paper's experiment: a central collision of a case's two particles, run through the same
/// scene, force kernel and integrator as any multi-particle run.

#include <functional>
#include <optional>

#include "solver/setup/case.hpp"

namespace bondem {

/// One time step of a collision, for traces.
struct CollisionSample {
  double time;          ///< [s]
  double overlap;       ///< delta [m], negative once apart
  double overlap_rate;  ///< d(delta)/dt [m/s], positive while approaching
  double normal_force;  ///< f . n_ij on the first particle [N]; negative = repulsion
  bool bonded;          ///< the pair is on the adhesive branch
};

/// Outcome of a collision.
struct CollisionResult {
  double restitution = 0.0;            ///< separation speed / impact speed; 0 when bonded
  bool bonded = false;                 ///< a bond is active at the end of the run
  bool bond_formed = false;            ///< a bond was active at some step
  double max_overlap = 0.0;            ///< [m]
  std::optional<double> contact_time;  ///< [s]; empty when the particles never separated
  double final_overlap = 0.0;          ///< overlap at the end, 0 once apart [m]
};

/// Collide the two particles of @p description head-on at relative speed @p velocity.
/// They are placed touching along the line joining their case positions (x if coincident), with
/// zero total momentum; gravity is ignored. The run lasts time.end or stops once they separate.
/// Throws std::invalid_argument unless the case has exactly two particles and velocity > 0.
CollisionResult collide(const Case& description, double velocity,
                        const std::function<void(const CollisionSample&)>& trace = {});

}  // namespace bondem
