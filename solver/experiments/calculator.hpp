#pragma once
/// @file calculator.hpp
/// Derived quantities of the bond model for one pair: what a user checks before a long run.

#include <string>
#include <vector>

#include "solver/models/bond_law.hpp"
#include "solver/setup/case.hpp"

namespace bondem {

/// Smallest impact speed whose undamped Hertz overlap reaches delta_crit, eq. 21 [m/s].
double critical_velocity(double e_star, double r_star, double m_star, double critical_overlap);

/// Rayleigh wave time pi r sqrt(rho / G) / (0.1631 nu + 0.8766) of a particle [s].
double rayleigh_time(double radius, const Material& material);

/// Largest time step at which velocity Verlet keeps a damped linear oscillator (stiffness k,
/// mass m, damping ratio xi) from growing, with the damper fed the half-step velocity as
/// Stepper::step() does: dt < 2 / (omega (sqrt(1 + xi^2) + xi)) = (2 / omega)(sqrt(1 + xi^2) - xi),
/// omega = sqrt(k / m) [s]. The one-step map of (x, v_half) has determinant 1 - 2 xi omega dt and
/// trace 2 - (omega dt)^2 - 2 xi omega dt; the Jury conditions give this bound (the determinant's
/// own bound, dt < 1 / (xi omega), is always the looser one).
double damped_stability_step(double stiffness, double mass, double damping_ratio);

/// Stiffness and damping per mass of the fastest mode, as multiples of one pair's (k / m*): the
/// safety factor of the damper limit. Equal spheres with central contacts have modes
/// omega^2 = (k / m) sum_j (n_j . e)^2 (1 - cos q.r_j) <= (2 k / m) z / 3 = (z / 3) k / m*, which
/// is 4 k / m* for the densest packing (z = 12); damping has the same structure. It also covers a
/// pair's tangential spring and damper, whose contact-point mass with rotation is m* / 3.5
/// (k_t <= k_con: omega^2 up to 3.5 k / m*, damping ratio up to 1.87 xi).
inline constexpr double kPackingModeFactor = 4.0;

/// The damper's time-step limit: damped_stability_step for the fastest packing mode, whose
/// stiffness and damping are kPackingModeFactor times one contact's (omega and xi both scale
/// with the square root of the factor) [s].
double damper_time_step(double stiffness, double mass, double damping_ratio);

/// Largest distance a tool may move in one step, as a fraction of the smallest particle radius:
/// a step then pushes a particle into a tool by at most this, far below the blow-up limit
/// (limits.max_overlap_fraction, 0.25 by default), so the contact law has steps to react.
inline constexpr double kMaxToolStepFraction = 0.05;

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
  bool bonding;                  ///< the case's bond criterion can bond this pair (not `never`)
  double reference_velocity;     ///< impact speed used for the two Hertz quantities below [m/s]
  const char* impact;            ///< what the normal-force law's impact is, for messages
  double max_overlap;            ///< undamped Hertz maximum overlap at the reference speed [m]
  double contact_time;           ///< undamped Hertz contact duration at the reference speed [s]
  double rayleigh_time;          ///< the smaller particle's Rayleigh time [s]
  double contact_stiffness;      ///< k_con = 2 E* sqrt(r* max_overlap), the stiffest impact [N/m]
  double contact_damper_step;    ///< damper_time_step() of k_con with xi_con [s]
  double bond_damper_step;       ///< damper_time_step() of k* with xi_bond; inf without bonds [s]
  double restitution;            ///< of the normal law at xi_con (restitution.hpp) [-]
  double recommended_time_step;  ///< see recommended_time_step()
};

/// Steps per contact below which a time step is reported as too coarse.
inline constexpr double kMinStepsPerContact = 30.0;

/// Steps that resolve a Hertz impact or a bond oscillation in the recommended time step.
inline constexpr double kStepsPerOscillation = 50.0;

/// Fraction of the Rayleigh time allowed as the recommended time step.
inline constexpr double kRayleighStepFraction = 0.2;

/// The recommended time step: min(t_contact / 50, T_bond / 50, 0.2 T_Rayleigh, damper limit).
/// Fifty steps resolve a Hertz impact (and a bond oscillation) to well under 1 % in overlap;
/// 0.2 T_Rayleigh is the usual DEM bound for dense packings where waves cross many contacts;
/// the damper limit (damper_time_step) keeps large damping ratios from amplifying motion.
double recommended_time_step(double contact_time, double bond_period, double rayleigh_time,
                             double damper_step);

/// Calculator for a pair of particles (material a, radius r_a) and (material b, radius r_b).
/// Throws std::invalid_argument for alpha_adh outside [0, 3/2) or non-positive inputs.
PairReport compute_pair_report(const Case& description, int material_a, double radius_a,
                               int material_b, double radius_b, double reference_velocity);

/// Warnings about the case's time step against a pair report (empty when none).
std::vector<std::string> time_step_warnings(const PairReport& report, double time_step);

/// Fastest speed of a tool's surface over its motion keys: translation plus what its shape's
/// spin adds (a roller's spin times its radius) [m/s].
double tool_surface_speed(const Boundary& tool);

/// Fastest impact a case can produce: twice its fastest initial particle, twice its fastest tool
/// surface (a struck particle leaves at up to twice the tool's speed), or a fall across the
/// domain (or the particles' extent) under gravity; 1 m/s when nothing moves [m/s].
double reference_impact_speed(const Case& description);

/// The time step a case must not exceed and what sets it.
struct TimeStepLimit {
  double step;        ///< [s]
  std::string cause;  ///< the rule and the pair, wall or tool that set it, for messages
};

/// The time step a case must not exceed: recommended_time_step() over every material pair at the
/// smallest radius of each material and at reference_impact_speed(); the contact damper of every
/// wall and tool against those particles (r* = r, m* = m); and no tool moving more than
/// kMaxToolStepFraction of the smallest radius per step. Throws std::invalid_argument, naming the
/// key at fault where it can, when a derived quantity is not finite.
TimeStepLimit case_time_step_bound(const Case& description);

/// case_time_step_bound(description).step [s].
double case_time_step_limit(const Case& description);

}  // namespace bondem
