#pragma once
/// @file rolling_law.hpp
/// Rolling resistance after Ai, Chen, Rotter & Ooi, "Assessment of rolling resistance models in
/// discrete element simulations", Powder Technology 206, 269 (2011): the constant directional
/// torque (their model type A) and the elastic-plastic spring-dashpot "EPSD" (their model type C).
/// Pure functions: no I/O, no allocation, no state beyond what the caller passes in.
///
/// The EPSD formulas below are those of Ai et al.'s model type C as restated, with the same
/// symbols, by the LIGGGHTS-PUBLIC documentation of `rolling_friction epsd`; the paper's own
/// equation numbers could not be checked against its text and are therefore not quoted.

#include <Eigen/Core>
#include <algorithm>
#include <cmath>

#include "solver/models/tangential_law.hpp"

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

/// EPSD rolling stiffness k_r = 2.25 k_n mu_r^2 R_r^2 (Ai et al. 2011, model type C, their 3D
/// prefactor), from the normal contact stiffness k_n [N/m], the rolling friction coefficient mu_r
/// and the rolling radius R_r = r* [m]. With it the spring reaches the limit mu_r R_r F_n after a
/// rolling angle of F_n / (2.25 k_n mu_r R_r), a fraction of the overlap over the radius [N m/rad].
inline double epsd_rolling_stiffness(double normal_stiffness, double rolling_friction,
                                     double r_star) {
  return 2.25 * normal_stiffness * rolling_friction * rolling_friction * r_star * r_star;
}

/// 1 / (I + m r^2): the rolling compliance of one partner about the contact point (parallel axis).
/// A wall or tool passes an infinite inertia or mass: its compliance is exactly zero, also when its
/// radius is zero (where inf * 0 would give NaN).
inline double rolling_compliance(double inertia, double mass, double radius) {
  if (std::isinf(inertia) || std::isinf(mass)) return 0.0;
  return 1.0 / (inertia + mass * radius * radius);
}

/// Equivalent moment of inertia of a pair for the relative rolling about the contact point,
/// 1/I_r = 1/(I_i + m_i r_i^2) + 1/(I_j + m_j r_j^2) (Ai et al. 2011, model type C) [kg m^2].
/// A wall or tool partner j passes @p inertia_j and @p mass_j as +infinity (any radius): its term
/// vanishes and I_r = I_i + m_i r_i^2, 7/5 m r^2 for a solid sphere.
inline double rolling_inertia(double inertia_i, double mass_i, double radius_i, double inertia_j,
                              double mass_j, double radius_j) {
  return 1.0 / (rolling_compliance(inertia_i, mass_i, radius_i) +
                rolling_compliance(inertia_j, mass_j, radius_j));
}

/// EPSD rolling damping C_r = eta_r C_r^crit = 2 eta_r sqrt(I_r k_r) (Ai et al. 2011, model type C;
/// they use eta_r = 0.3): the damping ratio @p damping_ratio of the rotational oscillator of
/// inertia I_r and stiffness k_r [N m s/rad].
inline double epsd_rolling_damping(double damping_ratio, double rolling_inertia,
                                   double rolling_stiffness) {
  return 2.0 * damping_ratio * std::sqrt(rolling_inertia * rolling_stiffness);
}

/// Result of the EPSD rolling law for one contact.
struct RollingSpringTorque {
  Eigen::Vector3d torque;  ///< rolling torque on particle i (j gets its opposite) [N m]
  Eigen::Vector3d spring;  ///< elastic torque M_r^k to store for the next step [N m]
  bool plastic;            ///< the spring is at its limit mu_r r* F_n (and the damper is off)
};

/// EPSD rolling torque (Ai et al. 2011, model type C): a rotational spring with history, limited
/// to the full-mobilisation torque M_m = mu_r R_r F_n, plus a dashpot that is off at that limit.
/// @param rolling_stiffness k_r (epsd_rolling_stiffness) [N m/rad]
/// @param damping        C_r (epsd_rolling_damping) [N m s/rad]
/// @param limit          M_m = mu_r r* F_n (>= 0) [N m]
/// @param normal         unit n_ij (from i to j)
/// @param spring         elastic torque stored last step (any orientation; rotated here) [N m]
/// @param relative_spin  omega_i - omega_j, as for rolling_torque [rad/s]
/// Only the rolling part of the relative spin, its projection on the tangent plane, turns the
/// spring and the damper: twisting about n is another mode (Ai et al. treat rolling only; LIGGGHTS
/// `epsd` by default and LAMMPS `rolling sds` do the same). The stored spring is first rotated
/// into the current tangent plane keeping its length, as tangential_force does with its
/// elongation, so a pair that rolls round each other keeps its torque. Then
/// M_k = M_k(old) - k_r omega_t dt; above M_m it is scaled back to M_m along itself (plastic, the
/// damper off, f = 0 in Ai et al.), else the torque is M_k - C_r omega_t.
inline RollingSpringTorque epsd_rolling_torque(double rolling_stiffness, double damping,
                                               double limit, const Eigen::Vector3d& normal,
                                               const Eigen::Vector3d& spring,
                                               const Eigen::Vector3d& relative_spin, double dt) {
  Eigen::Vector3d m = rotate_into_tangent_plane(spring, normal);
  const Eigen::Vector3d rolling_spin = relative_spin - relative_spin.dot(normal) * normal;
  m -= rolling_stiffness * (rolling_spin * dt);
  const double magnitude_sq = m.squaredNorm();
  if (magnitude_sq > limit * limit) {
    m *= limit / std::sqrt(magnitude_sq);
    return {m, m, true};
  }
  return {m - damping * rolling_spin, m, false};
}

}  // namespace bondem
