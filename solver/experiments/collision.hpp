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
  /// Separation speed when the contact ends / impact speed; 0 while still in contact.
  double restitution = 0.0;
  bool bonded = false;  ///< a bond is active at the end of the run
  /// The pair is still in contact at the end of the run, held by a bond or by its JKR contact.
  bool stuck = false;
  bool bond_formed = false;            ///< a bond was active at some step
  double max_overlap = 0.0;            ///< [m]
  std::optional<double> contact_time;  ///< [s]; empty when the contact never ended
  double final_overlap = 0.0;          ///< overlap at the end (< 0 held by JKR), 0 once apart [m]
};

/// Collide the two particles of @p description head-on at relative speed @p velocity.
/// They are placed touching along the line joining their case positions (x if coincident), with
/// zero total momentum; gravity is ignored. The run lasts time.end or stops once the contact ends:
/// the force kernel no longer holds the pair (overlap <= 0, or for a JKR pair below its separation
/// overlap).
/// Throws std::invalid_argument unless the case has exactly two particles and velocity > 0.
CollisionResult collide(const Case& description, double velocity,
                        const std::function<void(const CollisionSample&)>& trace = {});

/// Impact speed at which a pair passes between sticking and rebounding.
struct StickingThreshold {
  double velocity;    ///< [m/s]
  bool sticks_below;  ///< true: stuck below the threshold (JKR); false: stuck above it (a bond)
};

/// Bisect the speed in [@p low, @p high] where CollisionResult::stuck changes, to a relative
/// precision @p precision. Empty unless the pair sticks at exactly one of @p low and @p high.
std::optional<StickingThreshold> sticking_threshold(const Case& description, double low,
                                                    double high, double precision = 1e-6);

}  // namespace bondem
