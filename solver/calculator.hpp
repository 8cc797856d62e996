#pragma once
/// @file calculator.hpp
/// Derived quantities of the bond model for one pair: what a user checks before a long run.

#include <string>
#include <vector>

#include "solver/case.hpp"

namespace bondem {

/// Largest overlap of an undamped Hertz impact at relative speed v, eq. 20 [m].
double hertz_max_overlap(double e_star, double r_star, double m_star, double velocity);

/// Duration of an undamped Hertz impact at relative speed v [s]: 2 I delta_max / v with
/// I = integral_0^1 (1 - x^(5/2))^(-1/2) dx = sqrt(pi) Gamma(7/5) / Gamma(9/10) = 1.4716.
double hertz_contact_time(double e_star, double r_star, double m_star, double velocity);

/// Smallest impact speed whose undamped Hertz overlap reaches delta_crit, eq. 21 [m/s].
double critical_velocity(double e_star, double r_star, double m_star, double critical_overlap);

/// Rayleigh wave time pi r sqrt(rho / G) / (0.1631 nu + 0.8766) of a particle [s].
double rayleigh_time(double radius, const Material& material);

/// The bond calculator's quantities for particles of two materials and radii.
struct PairReport {
  double effective_modulus;      ///< E* [Pa]
  double effective_radius;       ///< r* [m]
  double effective_mass;         ///< m* [kg]
  double adhesion_stiffness;     ///< k_adh [N/m^alpha]
  double equilibrium_overlap;    ///< delta_eq [m]
  double critical_overlap;       ///< delta_crit [m]
  double critical_velocity;      ///< v_crit, eq. 21 [m/s]
  double bond_stiffness;         ///< k* at delta_eq, eq. 24 [N/m]
  double bond_period;            ///< 2 pi sqrt(m* / k*(delta_eq)), small oscillations of a bond [s]
  double reference_velocity;     ///< impact speed used for the two Hertz quantities below [m/s]
  double max_overlap;            ///< undamped Hertz maximum overlap at the reference speed [m]
  double contact_time;           ///< undamped Hertz contact duration at the reference speed [s]
  double rayleigh_time;          ///< the smaller particle's Rayleigh time [s]
  double recommended_time_step;  ///< see recommended_time_step()
};

/// Steps per contact below which a time step is reported as too coarse.
inline constexpr double kMinStepsPerContact = 30.0;

/// The recommended time step: min(t_contact / 50, T_bond / 50, 0.2 T_Rayleigh).
/// Fifty steps resolve a Hertz impact (and a bond oscillation) to well under 1 % in overlap;
/// 0.2 T_Rayleigh is the usual DEM bound for dense packings where waves cross many contacts.
double recommended_time_step(double contact_time, double bond_period, double rayleigh_time);

/// Calculator for a pair of particles (material a, radius r_a) and (material b, radius r_b).
/// Throws std::invalid_argument for alpha_adh outside [0, 3/2) or non-positive inputs.
PairReport compute_pair_report(const Case& description, int material_a, double radius_a,
                               int material_b, double radius_b, double reference_velocity);

/// Warnings about the case's time step against a pair report (empty when none).
std::vector<std::string> time_step_warnings(const PairReport& report, double time_step);

/// Fastest impact a case can produce: twice its fastest initial particle, or a fall across the
/// domain (or the particles' extent) under gravity; 1 m/s when nothing moves [m/s].
double reference_impact_speed(const Case& description);

/// The time step a case must not exceed: recommended_time_step() over every material pair at the
/// smallest radius of each material and at reference_impact_speed().
double case_time_step_limit(const Case& description);

}  // namespace bondem
