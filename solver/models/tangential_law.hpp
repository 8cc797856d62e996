#pragma once
/// @file tangential_law.hpp
/// Tangential contact: a Mindlin no-slip spring with history, a dashpot and the Coulomb limit.
/// Pure functions: no I/O, no allocation, no state beyond what the caller passes in.

#include <Eigen/Core>
#include <cmath>

namespace bondem {

/// Result of the tangential law for one contact.
struct TangentialForce {
  Eigen::Vector3d force;  ///< on particle i [N]
  Eigen::Vector3d slip;   ///< updated spring elongation to store for the next step [m]
  bool sliding;           ///< the Coulomb limit was reached
};

/// Mindlin no-slip stiffness k_t = 8 G* a for a contact of radius a = sqrt(r* delta) [N/m].
/// Callers pass a as sqrt(r*) sqrt(delta): both roots are already taken for the normal law.
inline double mindlin_stiffness(double shear_modulus_star, double contact_radius) {
  return 8.0 * shear_modulus_star * contact_radius;
}

/// Tangential dashpot d_t = 2 xi sqrt(m* k_t): the normal contact's damping ratio xi applied to the
/// tangential spring k_t and the pair's effective mass m* (m for a particle on a wall) [N s/m].
inline double tangential_damping(double damping_ratio, double mass, double stiffness) {
  return 2.0 * damping_ratio * std::sqrt(mass * stiffness);
}

/// The part of the relative contact velocity @p contact_velocity in the tangent plane of the unit
/// @p normal: the velocity that slides the surfaces over each other.
inline Eigen::Vector3d sliding_velocity(const Eigen::Vector3d& contact_velocity,
                                        const Eigen::Vector3d& normal) {
  return contact_velocity - contact_velocity.dot(normal) * normal;
}

/// A stored spring @p spring (an elongation or a torque) turned into the tangent plane of the unit
/// @p normal, keeping its length, so that a contact that rolls keeps what its spring holds.
inline Eigen::Vector3d rotate_into_tangent_plane(const Eigen::Vector3d& spring,
                                                 const Eigen::Vector3d& normal) {
  Eigen::Vector3d s = spring - spring.dot(normal) * normal;
  // Rescale to the stored length; squared norms spare the square roots of a fresh contact
  // (zero spring) and of a spring already in the plane.
  const double before_sq = spring.squaredNorm();
  const double after_sq = s.squaredNorm();
  if (after_sq > 0.0 && after_sq != before_sq) s *= std::sqrt(before_sq / after_sq);
  return s;
}

/// Cundall-Strack tangential spring with history.
/// @param normal        unit n_ij (from i to j)
/// @param slip          elongation stored last step (any orientation; projected here)
/// @param sliding_velocity tangential velocity of j relative to i at the contact point
/// @param load          normal load the Coulomb limit is proportional to (>= 0) [N]
/// The stored elongation is first rotated into the current tangent plane (keeping its length, so
/// a rolling pair does not lose its spring), then advanced by v_t dt. The trial force
/// k_t s + d_t v_t drags i along with j; above mu * load it is scaled back and the spring set to
/// the elongation that carries the limit force.
inline TangentialForce tangential_force(double stiffness, double damping, double friction,
                                        double load, const Eigen::Vector3d& normal,
                                        const Eigen::Vector3d& slip,
                                        const Eigen::Vector3d& sliding_velocity, double dt) {
  Eigen::Vector3d s = rotate_into_tangent_plane(slip, normal);
  s += sliding_velocity * dt;
  Eigen::Vector3d force = stiffness * s + damping * sliding_velocity;
  const double limit = friction * load;
  const double magnitude_sq = force.squaredNorm();
  if (magnitude_sq > limit * limit) {
    const double magnitude = std::sqrt(magnitude_sq);
    force *= limit / magnitude;
    s = stiffness > 0.0 ? Eigen::Vector3d(force / stiffness) : Eigen::Vector3d::Zero();
    return {force, s, true};
  }
  return {force, s, false};
}

}  // namespace bondem
