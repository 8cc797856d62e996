#pragma once
/// @file pair.hpp
/// Effective pair quantities (eq. 11-14) and the per-material-pair coefficients of the bond law.

#include <cmath>

#include "solver/models/bond_law.hpp"

namespace bondem {

/// Effective radius r* = r_i r_j / (r_i + r_j).
constexpr double effective_radius(double r_i, double r_j) {
  return r_i * r_j / (r_i + r_j);
}

/// Effective mass m* = m_i m_j / (m_i + m_j), eq. 11.
constexpr double effective_mass(double m_i, double m_j) {
  return m_i * m_j / (m_i + m_j);
}

/// Effective modulus E* = E_i E_j / (E_j (1 - nu_i^2) + E_i (1 - nu_j^2)), eq. 12.
constexpr double effective_modulus(double e_i, double nu_i, double e_j, double nu_j) {
  return e_i * e_j / (e_j * (1.0 - nu_i * nu_i) + e_i * (1.0 - nu_j * nu_j));
}

/// Hertz stiffness (4/3) E* sqrt(r*), the k_2 of eq. 12.
inline double hertz_stiffness(double e_star, double r_star) {
  return 4.0 / 3.0 * e_star * std::sqrt(r_star);
}

/// Radius a of the contact spot of a pair with effective radius r* at overlap delta > 0, formed as
/// sqrt(r*) sqrt(delta): the same a as contact_radius() (heat_law.hpp) up to rounding, in the form
/// the contact laws have always used (and their outputs' bytes depend on).
inline double spot_radius(double r_star, double overlap) {
  return std::sqrt(r_star) * std::sqrt(overlap);
}

/// How a case sets the adhesion strength: k_adh directly, or the overlap the bond settles at.
enum class AdhesionInput { kStiffness, kEquilibriumOverlap };

/// How a contact resists rolling (Ai, Chen, Rotter & Ooi, Powder Technol. 206, 269, 2011).
enum class RollingModel {
  kConstantTorque,  ///< model A: -mu_r r* F_n against the relative spin, no history
  kEpsd,            ///< model C: elastic-plastic spring-dashpot, its spring carried as history
};

/// Surface-energy cohesion of a contact, beside the bond law (which replaces it once bonded).
enum class CohesionModel {
  kNone,
  kSjkr,  ///< simplified JKR: attraction = energy density x contact area (LIGGGHTS sjkr)
  kJkr,   ///< Johnson-Kendall-Roberts, with the hysteresis of its separation overlap
};

/// Coefficients of one material pair, computed once; r* and m* vary per contact.
struct PairCoefficients {
  double effective_modulus = 0.0;  ///< E* [Pa]
  double contact_damping = 0.0;    ///< xi_con
  double restitution = 0.0;        ///< e the damping ratio was derived from; 0 when xi_con given
  double bond_damping = 0.0;       ///< xi_bond
  double alpha = 1.0;              ///< alpha_adh
  AdhesionInput input = AdhesionInput::kEquilibriumOverlap;
  double adhesion_stiffness = 0.0;   ///< k_adh, when input == kStiffness
  double equilibrium_overlap = 0.0;  ///< delta_eq, when input == kEquilibriumOverlap
  // Derived once so that contacts need no std::pow when alpha = 1 or delta_eq is fixed.
  double equilibrium_power = 0.0;  ///< delta_eq^(3/2 - alpha), when input == kEquilibriumOverlap
  double critical_ratio = 0.0;     ///< delta_crit / delta_eq = (2 alpha / 3)^(1 / (3/2 - alpha))
  double shear_modulus = 0.0;      ///< G* = 1 / ((2 - nu_i)/G_i + (2 - nu_j)/G_j), Mindlin [Pa]
  double friction = 0.0;           ///< Coulomb sliding friction mu
  double rolling_friction = 0.0;   ///< rolling resistance mu_r (dimensionless, times r*)
  RollingModel rolling_model = RollingModel::kConstantTorque;
  double rolling_damping = 0.0;  ///< eta_r of the EPSD rolling damper
  CohesionModel cohesion = CohesionModel::kNone;
  double cohesion_energy = 0.0;  ///< sjkr energy density [J/m^3] or jkr surface energy [J/m^2]
  BondCriterion criterion = BondCriterion::kNever;  ///< when two particles of the pair bond
  double bond_temperature = 0.0;                    ///< [K] of criterion kTemperature
  double conductivity = 0.0;  ///< k_eff, harmonic mean of the two conductivities [W/(m K)]
};

/// Effective shear modulus G* of Mindlin's tangential stiffness.
constexpr double effective_shear_modulus(double e_i, double nu_i, double e_j, double nu_j) {
  const double g_i = e_i / (2.0 * (1.0 + nu_i));
  const double g_j = e_j / (2.0 * (1.0 + nu_j));
  return 1.0 / ((2.0 - nu_i) / g_i + (2.0 - nu_j) / g_j);
}

/// Coefficients of a material pair with modulus E*, damping ratios and the case's bond input.
/// @param strength k_adh when input == kStiffness, delta_eq when input == kEquilibriumOverlap.
inline PairCoefficients make_pair_coefficients(double e_star, double xi_con, double xi_bond,
                                               double alpha, AdhesionInput input, double strength) {
  PairCoefficients c;
  c.effective_modulus = e_star;
  c.contact_damping = xi_con;
  c.bond_damping = xi_bond;
  c.alpha = alpha;
  c.input = input;
  const double exponent = 1.5 - alpha;
  if (input == AdhesionInput::kStiffness) {
    c.adhesion_stiffness = strength;
  } else {
    c.equilibrium_overlap = strength;
    c.equilibrium_power = std::pow(strength, exponent);
  }
  // From eq. 13 and 14: delta_crit = (alpha k_adh / (2 E* sqrt r*))^(1/e) = (2 alpha/3)^(1/e)
  // delta_eq.
  c.critical_ratio = std::pow(2.0 * alpha / 3.0, 1.0 / exponent);
  return c;
}

/// The law's coefficients for one contact of a material pair with effective radius and mass.
inline BondPair make_bond_pair(const PairCoefficients& c, double r_star, double m_star) {
  const double k_hertz = hertz_stiffness(c.effective_modulus, r_star);
  double k_adh = c.adhesion_stiffness;
  double delta_eq = c.equilibrium_overlap;
  if (c.input == AdhesionInput::kEquilibriumOverlap) {
    k_adh = k_hertz * c.equilibrium_power;  // eq. 13 solved for k_adh
  } else if (c.alpha == 1.0) {
    const double ratio = k_adh / k_hertz;  // eq. 13 with 1 / (3/2 - 1) = 2
    delta_eq = ratio * ratio;
  } else {
    delta_eq = std::pow(k_adh / k_hertz, 1.0 / (1.5 - c.alpha));  // eq. 13
  }
  return BondPair{k_hertz,           m_star,         k_adh,  delta_eq, c.critical_ratio * delta_eq,
                  c.contact_damping, c.bond_damping, c.alpha};
}

/// The law's coefficients for a particle of @p radius and @p mass on a wall or tool: a sphere of
/// infinite radius and mass (r* = r, m* = m) that never bonds.
inline BondPair make_wall_pair(const PairCoefficients& c, double radius, double mass) {
  return BondPair{
      hertz_stiffness(c.effective_modulus, radius), mass, 0.0, 0.0, 0.0, c.contact_damping, 0.0};
}

}  // namespace bondem
