#pragma once
/// @file contact_laws.hpp
/// One contact composed of the sub-models its material pair chose (PairCoefficients): the normal
/// law with its bond, cohesion (none, sJKR or JKR), the tangential law and rolling resistance
/// (constant torque or EPSD). Particle pairs and particles on a boundary call the same two
/// functions; a boundary is a partner of infinite radius and mass (r* = r, m* = m, 1/I = 0) that
/// never bonds.
///
/// Pure functions: the caller measures the kinematics and owns the history it passes in.

#include <Eigen/Core>
#include <cmath>

#include "solver/models/bond_law.hpp"
#include "solver/models/cohesion_law.hpp"
#include "solver/models/pair.hpp"
#include "solver/models/rolling_law.hpp"
#include "solver/models/tangential_law.hpp"

namespace bondem {

/// The normal part of a contact.
struct ContactNormal {
  double force;  ///< f . n_ij on i [N]; negative = repulsion
  double load;   ///< the normal load that limits friction (>= 0) [N]
  /// Radius of the contact spot where a model sets it (JKR); 0: the Hertz spot sqrt(r* delta),
  /// computed only where it is needed.
  double contact_radius;
  bool bonded;  ///< on the adhesive branch of the bond law (eq. 25)
  bool joined;  ///< a JKR contact, which holds until the separation overlap
};

/// Overlap below which a JKR contact of the pair (r*, E*, w) breaks: negative (the surfaces part
/// only once pulled apart by it); 0 for a pair without JKR cohesion.
inline double separation_overlap(const PairCoefficients& c, double r_star) {
  return c.cohesion == CohesionModel::kJkr
             ? jkr_separation_overlap(r_star, c.effective_modulus, c.cohesion_energy)
             : 0.0;
}

/// JKR contact at @p overlap (>= the separation overlap) approaching at @p overlap_rate: the
/// Hertz part at JKR's contact radius a with the pair's damper (stiffness 2 E* a), clamped so that
/// it never attracts, plus the adhesive part. Friction is limited by the damped repulsion.
[[gnu::noinline]] inline ContactNormal jkr_contact(const PairCoefficients& c, double r_star,
                                                   double m_star, double overlap,
                                                   double overlap_rate) {
  const JkrForce jkr = jkr_force(overlap, r_star, c.effective_modulus, c.cohesion_energy);
  const double stiffness = jkr_contact_stiffness(jkr.contact_radius, c.effective_modulus);
  const double damping = 2.0 * c.contact_damping * std::sqrt(m_star * stiffness);
  const double repulsion = std::fmin(jkr.elastic - damping * overlap_rate, 0.0);
  return {repulsion + jkr.adhesive, -repulsion, jkr.contact_radius, false, true};
}

/// The normal part of a contact of pair coefficients @p c (law pair @p pair, effective radius and
/// mass @p r_star, @p m_star) at @p overlap, approaching at @p overlap_rate. A bond (where
/// @p criterion_met and past delta_crit) replaces cohesion; sJKR adds its attraction to the
/// damped contact; JKR replaces the contact. @p overlap may be <= 0 only for a JKR pair whose
/// contact still holds. Without kModels (no pair of the scene has cohesion or EPSD rolling) only
/// the normal law runs.
template <bool kModels, class Law>
[[gnu::always_inline]] inline ContactNormal contact_normal(
    const Law& law, const PairCoefficients& c, const typename Law::Pair& pair, double r_star,
    double m_star, double overlap, double overlap_rate, bool criterion_met) {
  // Every law call stays inline (a law pair passed out of line would live in memory); only
  // JKR's contact, which needs no law pair, is a call.
  if (!kModels || c.cohesion == CohesionModel::kNone) {
    const NormalForce f = law.force(pair, overlap, overlap_rate, criterion_met);
    return {f.force, law.friction_load(pair, f, overlap), 0.0, f.bonded, false};
  }
  if (overlap > 0.0) {
    const NormalForce f = law.force(pair, overlap, overlap_rate, criterion_met);
    if (f.bonded) return {f.force, law.friction_load(pair, f, overlap), 0.0, true, false};
    if (c.cohesion == CohesionModel::kSjkr) {
      return {f.force + sjkr_force(c.cohesion_energy, r_star, overlap),
              law.friction_load(pair, f, overlap), 0.0, false, false};
    }
  }
  return jkr_contact(c, r_star, m_star, overlap, overlap_rate);
}

/// What the tangential and rolling laws give a contact: the force and rolling torque on i.
struct ContactFriction {
  Eigen::Vector3d force;
  Eigen::Vector3d rolling_torque;
};

/// EPSD rolling torque on i of a contact with normal stiffness @p k_n pressed by @p load, pair
/// inertia @p inertia (I*); updates @p rolling_spring. Out of line: the common contacts keep
/// their springs in registers.
[[gnu::noinline]] inline Eigen::Vector3d epsd_contact_torque(
    double k_n, const PairCoefficients& c, double load, double r_star, double inertia,
    const Eigen::Vector3d& normal, const Eigen::Vector3d& relative_spin,
    Eigen::Vector3d& rolling_spring, double dt) {
  // A solid sphere about a point of its surface has I + m r^2 = 7/2 I, so the pair's rolling
  // inertia 1 / (1/(I_i + m_i r_i^2) + 1/(I_j + m_j r_j^2)) is 7/2 of I*.
  const double k_r = epsd_rolling_stiffness(k_n, c.rolling_friction, r_star);
  const double damping = epsd_rolling_damping(c.rolling_damping, 3.5 * inertia, k_r);
  const RollingSpringTorque r = epsd_rolling_torque(
      k_r, damping, c.rolling_friction * r_star * load, normal, rolling_spring, relative_spin, dt);
  rolling_spring = r.spring;
  return r.torque;
}

/// Friction and rolling resistance of a contact with normal part @p n.
/// @param normal unit n_ij; @param sliding velocity of j's surface relative to i's at the contact,
/// tangential; @param relative_spin omega_i - omega_j (a boundary: omega_i).
/// @param inverse_inertia callable giving 1/I_i + 1/I_j (a boundary: 1/I_i), called only where
/// the pair has rolling resistance.
/// @param rolling whether rolling resistance is evaluated (the scene stores rolling torques).
/// @param slip the tangential spring elongation, updated; @param rolling_spring the EPSD rolling
/// spring torque, updated (read only by EPSD pairs, which exist only with kModels).
template <bool kModels, class Law, class InverseInertia>
[[gnu::always_inline]] inline ContactFriction contact_friction(
    const Law& law, const PairCoefficients& c, const ContactNormal& n, double r_star, double m_star,
    double overlap, const Eigen::Vector3d& normal, const Eigen::Vector3d& sliding,
    const Eigen::Vector3d& relative_spin, InverseInertia inverse_inertia, bool rolling,
    Eigen::Vector3d& slip, Eigen::Vector3d& rolling_spring, double dt) {
  const double radius =
      kModels && n.contact_radius > 0.0 ? n.contact_radius : spot_radius(r_star, overlap);
  const double k_t = mindlin_stiffness(c.shear_modulus, radius);
  const double d_t = tangential_damping(c.contact_damping, m_star, k_t);
  const TangentialForce t =
      tangential_force(k_t, d_t, c.friction, n.load, normal, slip, sliding, dt);
  slip = t.slip;
  ContactFriction out{t.force, Eigen::Vector3d::Zero()};
  if (!rolling || c.rolling_friction == 0.0) return out;
  const double inertia = effective_inertia(inverse_inertia(), 0.0);
  if (!kModels || c.rolling_model == RollingModel::kConstantTorque) {
    out.rolling_torque =
        rolling_torque(c.rolling_friction, r_star, n.load, relative_spin, inertia, dt);
    return out;
  }
  out.rolling_torque = epsd_contact_torque(law.normal_stiffness(c, radius), c, n.load, r_star,
                                           inertia, normal, relative_spin, rolling_spring, dt);
  return out;
}

}  // namespace bondem
