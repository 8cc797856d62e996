#pragma once
/// @file bond_law.hpp
/// The Hertz + adhesion bond law of Quintana-Ruiz & Campello (eq. 15-26), normal direction only.
///
/// Pure functions: no I/O, no allocation, no state. Forces are the scalar component f . n_ij of the
/// force on particle i, where n_ij points from i to j: negative pushes i away from j (repulsion),
/// positive pulls i toward j (attraction). Particle j receives the opposite force.

#include <algorithm>
#include <cmath>
#include <numbers>

namespace bondem {

/// When the adhesive term may act (eq. 25, "and the bond criterion is met").
enum class BondCriterion {
  kAlways,    ///< every pair past the critical overlap bonds
  kNever,     ///< pure damped Hertz, no adhesion
  kPairFlag,  ///< the caller decides per pair (e.g. both particles above a melt temperature)
  /// Both particles at or above the bonding temperature; a bond so formed persists (the neck has
  /// solidified) until its overlap falls back to delta_crit.
  kTemperature,
};

/// True when the adhesive term may act for a pair whose caller-supplied flag is @p pair_flag.
constexpr bool criterion_holds(BondCriterion criterion, bool pair_flag) {
  switch (criterion) {
    case BondCriterion::kAlways:
      return true;
    case BondCriterion::kNever:
      return false;
    case BondCriterion::kPairFlag:
    case BondCriterion::kTemperature:
      return pair_flag;
  }
  return false;
}

/// Criterion kTemperature for a pair at temperatures @p t_i, @p t_j: both at or above
/// @p bond_temperature, or @p bonded already (a solidified neck does not melt away as the particles
/// cool; it is lost only when the overlap falls back to delta_crit).
inline bool temperature_criterion(bool bonded, double t_i, double t_j, double bond_temperature) {
  return bonded || (t_i >= bond_temperature && t_j >= bond_temperature);
}

/// Adhesion exponent alpha_adh = 1 (the paper's choice): integer powers only, no std::pow.
struct LinearAdhesion {
  double alpha() const { return 1.0; }
  /// delta^alpha
  double power(double overlap) const { return overlap; }
  /// delta^(alpha - 1)
  double power_minus_one(double /*overlap*/) const { return 1.0; }
};

/// Any adhesion exponent 0 <= alpha_adh < 3/2 (stability, eq. 9 and 14).
struct GeneralAdhesion {
  double exponent;
  double alpha() const { return exponent; }
  double power(double overlap) const { return std::pow(overlap, exponent); }
  double power_minus_one(double overlap) const { return std::pow(overlap, exponent - 1.0); }
};

/// Coefficients of one contacting pair, all derived from materials and radii (see pair.hpp).
struct BondPair {
  double hertz_stiffness;      ///< (4/3) E* sqrt(r*)  [N/m^1.5]
  double effective_mass;       ///< m* = m_i m_j / (m_i + m_j)  [kg]
  double adhesion_stiffness;   ///< k_adh  [N/m^alpha]
  double equilibrium_overlap;  ///< delta_eq, eq. 13  [m]
  double critical_overlap;     ///< delta_crit, eq. 14  [m]
  double contact_damping;      ///< xi_con, eq. 26
  double bond_damping;         ///< xi_bond, eq. 23
  double alpha = 1.0;          ///< alpha_adh of the pair's bond
};

/// Result of evaluating the law for one pair.
struct NormalForce {
  double force;  ///< f . n_ij on particle i [N]; negative = repulsion
  bool bonded;   ///< the adhesive branch of eq. 25 was used
};

/// Damped Hertz contact (eq. 26) with its sign rule: a contact never attracts.
inline double hertz_contact_force(const BondPair& pair, double overlap, double overlap_rate) {
  const double sqrt_overlap = std::sqrt(overlap);
  const double elastic = pair.hertz_stiffness * overlap * sqrt_overlap;
  // k_con = 2 E* sqrt(r*) delta^(1/2) = 1.5 (4/3) E* sqrt(r*) delta^(1/2)
  const double stiffness = 1.5 * pair.hertz_stiffness * sqrt_overlap;
  const double damping = 2.0 * pair.contact_damping * std::sqrt(pair.effective_mass * stiffness);
  const double force = -elastic - damping * overlap_rate;
  return force > 0.0 ? 0.0 : force;
}

/// Bond force (eq. 15, 22-24) with the two sign rules of Sec. 4: the total always restores toward
/// delta_eq. Valid for overlap > delta_crit, where the tangent stiffness k* is positive.
template <class Adhesion>
double bond_force(const BondPair& pair, Adhesion adhesion, double overlap, double overlap_rate) {
  const double sqrt_overlap = std::sqrt(overlap);
  const double elastic = -pair.hertz_stiffness * overlap * sqrt_overlap +
                         pair.adhesion_stiffness * adhesion.power(overlap);
  const double tangent_stiffness =
      1.5 * pair.hertz_stiffness * sqrt_overlap -
      adhesion.alpha() * pair.adhesion_stiffness * adhesion.power_minus_one(overlap);
  // k* is zero at delta_crit by construction; clamp round-off so the square root stays real.
  const double damping =
      2.0 * pair.bond_damping * std::sqrt(pair.effective_mass * std::fmax(tangent_stiffness, 0.0));
  const double force = elastic - damping * overlap_rate;
  const bool compressed = overlap > pair.equilibrium_overlap;
  if (compressed && force > 0.0) return 0.0;
  if (!compressed && force < 0.0) return 0.0;
  return force;
}

/// The total normal force of eq. 25 for a pair in contact (overlap > 0).
/// @param overlap_rate d(delta)/dt, positive while the particles approach.
/// @param criterion_met whether the bonding criterion holds for this pair (see criterion_holds).
template <class Adhesion>
NormalForce normal_force(const BondPair& pair, Adhesion adhesion, double overlap,
                         double overlap_rate, bool criterion_met) {
  if (criterion_met && overlap > pair.critical_overlap) {
    return {bond_force(pair, adhesion, overlap, overlap_rate), true};
  }
  return {hertz_contact_force(pair, overlap, overlap_rate), false};
}

/// The normal load that limits a contact's friction (Coulomb mu * load). A bond presses the
/// surfaces together with its Hertz part even where the net normal force vanishes (at delta_eq):
/// that load, not the net force, limits its friction. A contact presses with -f (never attracts).
inline double friction_load(const BondPair& pair, const NormalForce& f, double overlap) {
  return f.bonded ? pair.hertz_stiffness * overlap * std::sqrt(overlap) : std::max(0.0, -f.force);
}

/// Largest overlap of an undamped Hertz impact at relative speed v, eq. 20 [m].
inline double hertz_max_overlap(double e_star, double r_star, double m_star, double velocity) {
  return std::pow(15.0 * m_star * velocity * velocity / (16.0 * e_star * std::sqrt(r_star)), 0.4);
}

/// Duration of an undamped Hertz impact at relative speed v [s]: 2 I delta_max / v with
/// I = integral_0^1 (1 - x^(5/2))^(-1/2) dx = sqrt(pi) Gamma(7/5) / Gamma(9/10) = 1.4716.
inline double hertz_contact_time(double e_star, double r_star, double m_star, double velocity) {
  static const double integral = std::sqrt(std::numbers::pi) * std::tgamma(1.4) / std::tgamma(0.9);
  return 2.0 * integral * hertz_max_overlap(e_star, r_star, m_star, velocity) / velocity;
}

/// Hertz tangent stiffness k_con = 2 E* sqrt(r* delta) = (3/2) (4/3) E* sqrt(r*) sqrt(delta) [N/m].
inline double hertz_tangent_stiffness(double e_star, double r_star, double overlap) {
  return 2.0 * e_star * std::sqrt(r_star * overlap);
}

/// Tangent stiffness k* of a bond at overlap delta, eq. 24:
/// 2 E* sqrt(r* delta) - alpha k_adh delta^(alpha - 1) [N/m].
inline double bond_tangent_stiffness(double e_star, double r_star, double alpha,
                                     double adhesion_stiffness, double overlap) {
  return 2.0 * e_star * std::sqrt(r_star * overlap) -
         alpha * adhesion_stiffness * std::pow(overlap, alpha - 1.0);
}

}  // namespace bondem
