#pragma once
/// @file rolling_law.hpp
/// Rolling resistance: constant directional torque (Ai et al. 2011, model A).
/// Pure function: no I/O, no allocation.

#include <Eigen/Core>
#include <algorithm>

namespace bondem {

/// Effective moment of inertia I* = I_i I_j / (I_i + I_j) = 1 / (1/I_i + 1/I_j) of a pair, from the
/// inverse inertias; a wall or tool has 1/I = 0, so a particle on it has I* = I_i [kg m^2].
inline double effective_inertia(double inverse_inertia_i, double inverse_inertia_j) {
  return 1.0 / (inverse_inertia_i + inverse_inertia_j);
}

/// Rolling-resistance torque on particle i: -mu_r r* F_n along the relative rolling direction
/// omega_i - omega_j. Its size is capped so that one step cannot reverse the relative spin
/// (|tau| <= I* |omega_rel| / dt), which removes the chatter model A shows at rest.
/// @param inertia effective moment of inertia I_i I_j / (I_i + I_j) (I_i against a wall) [kg m^2]
inline Eigen::Vector3d rolling_torque(double rolling_friction, double r_star, double load,
                                      const Eigen::Vector3d& relative_spin, double inertia,
                                      double dt) {
  if (rolling_friction == 0.0) return Eigen::Vector3d::Zero();
  const double spin = relative_spin.norm();
  if (spin == 0.0) return Eigen::Vector3d::Zero();
  const double magnitude = std::min(rolling_friction * r_star * load, inertia * spin / dt);
  return -magnitude / spin * relative_spin;
}

}  // namespace bondem
