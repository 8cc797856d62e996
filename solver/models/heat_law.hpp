#pragma once
/// @file heat_law.hpp
/// Thermal coupling of particles (powder-bed fusion): conduction through contact spots, exchange
/// with the surroundings, and the explicit time-step rule for the temperature equation
///
///     C_i dT_i/dt = sum_j H_ij (T_j - T_i) + Q_i,    C_i = m_i c_p,i
///
/// Pure functions: no I/O, no allocation, no state. SI units throughout (W, K, J/K, m). A heat
/// flow is the power INTO particle i: the contact term H (T_j - T_i) is positive when j is hotter.
///
/// Explicit time step. Forward Euler on the conduction part gives
///     T_i' = (1 - dt sum_j H_ij / C_i) T_i + sum_j (dt H_ij / C_i) T_j,
/// whose weights sum to 1. When dt sum_j H_ij / C_i <= 1 for every particle they are all >= 0, so
/// every new temperature is a convex combination of old ones: a discrete maximum principle (no new
/// extremum can appear), hence the scheme is stable and does not oscillate. The step must
/// therefore satisfy dt <= min_i thermal_time_step_limit(C_i, sum_j H_ij). Above the limit the
/// weight of T_i turns negative and the hottest particle can overshoot below its coldest
/// neighbour. Exchange with the surroundings fits the same rule if the ambient is counted as a
/// neighbour of infinite capacity: add h A to the particle's total conductance for convection and
/// 4 eps sigma A max(T, T_amb)^3 for radiation (a bound on the secant slope of T^4 - T_amb^4).
///
/// Exact reference: two bodies of capacities C1, C2 joined by a constant conductance H relax as
///     Delta T(t) = Delta T0 exp(-H (1/C1 + 1/C2) t),  Delta T = T1 - T2,
/// while C1 T1 + C2 T2 stays constant (forward Euler conserves it exactly, up to rounding, because
/// the same flux leaves one body and enters the other).

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace bondem {

/// Stefan-Boltzmann constant sigma [W m^-2 K^-4] (CODATA 2018, exact in the 2019 SI).
inline constexpr double kStefanBoltzmann = 5.670374419e-8;

/// Hertz contact radius a = sqrt(r* delta) [m] for effective radius r* and overlap delta; 0 when
/// the particles do not overlap (delta <= 0).
inline double contact_radius(double r_star, double overlap) {
  return overlap > 0.0 ? std::sqrt(r_star * overlap) : 0.0;
}

/// Effective conductivity of a contact between materials of conductivity k_i, k_j [W/(m K)]:
/// 2 k_i k_j / (k_i + k_j). Equals k for equal materials and 0 when either side is an insulator.
inline double harmonic_conductivity(double k_i, double k_j) {
  const double sum = k_i + k_j;
  // The guard only matters for k_i = k_j = 0, which would otherwise give 0/0.
  return sum > 0.0 ? 2.0 * k_i * k_j / sum : 0.0;
}

/// Conductance of a contact spot of radius @p a between two particles, H = 2 k_eff a [W/K], with
/// k_eff = harmonic_conductivity(k_i, k_j); the heat flow into i is H (T_j - T_i).
/// This is Batchelor & O'Brien's (1977) solid-solid contact conductance: each particle, seen from
/// a contact spot much smaller than itself (a << r), is a half-space whose constriction resistance
/// is 1 / (4 k a) (Holm); the two in series give 4 a k_i k_j / (k_i + k_j) = 2 k_eff a. It neglects
/// conduction through the gas gap and the particle's own bulk resistance, so it holds for
/// a << r and a / r >> k_gas / k_solid.
inline double contact_conductance(double k_i, double k_j, double a) {
  return 2.0 * harmonic_conductivity(k_i, k_j) * a;
}

/// The same conductance from an effective conductivity already formed per material pair:
/// H = 2 k_eff a [W/K].
inline double spot_conductance(double k_eff, double a) {
  return 2.0 * k_eff * a;
}

/// Heat flow into a body at @p t_self through a contact of @p conductance H with a body (particle
/// or wall) at @p t_other: H (T_other - T_self) [W].
inline double contact_heat_flow(double conductance, double t_self, double t_other) {
  return conductance * (t_other - t_self);
}

/// Conductance that radiation adds to the explicit step limit: the slope of eps sigma A T^4
/// between T and T_amb is at most 4 eps sigma A max(T, T_amb)^3 [W/K].
inline double radiation_conductance(double emissivity, double area, double t_ambient, double t) {
  const double hotter = std::max(t, t_ambient);
  return 4.0 * emissivity * kStefanBoltzmann * area * hotter * hotter * hotter;
}

/// Convective heat gained from the surroundings, h A (T_amb - T) [W]; negative for a hot particle.
/// @param h heat-transfer coefficient [W/(m^2 K)], @p area exposed area [m^2].
inline double convection_heat(double h, double area, double t_ambient, double t) {
  return h * area * (t_ambient - t);
}

/// Radiative heat gained from surroundings at @p t_ambient, eps sigma A (T_amb^4 - T^4) [W];
/// negative for a particle hotter than its surroundings. Temperatures in kelvin.
inline double radiation_heat(double emissivity, double area, double t_ambient, double t) {
  const double ambient2 = t_ambient * t_ambient;
  const double t2 = t * t;
  return emissivity * kStefanBoltzmann * area * (ambient2 * ambient2 - t2 * t2);
}

/// A particle's exchange with its surroundings: the heat it gains and the conductance that the
/// exchange adds to the explicit step limit.
struct SurroundingsExchange {
  double heat;         ///< convection + radiation into the particle [W]
  double conductance;  ///< h A + radiation_conductance() [W/K]
};

/// Convection (coefficient @p h) and radiation (@p emissivity) of a particle of exposed @p area at
/// temperature @p t to surroundings at @p t_ambient.
inline SurroundingsExchange surroundings_exchange(double h, double emissivity, double area,
                                                  double t_ambient, double t) {
  return {convection_heat(h, area, t_ambient, t) + radiation_heat(emissivity, area, t_ambient, t),
          h * area + radiation_conductance(emissivity, area, t_ambient, t)};
}

/// Surface area of a sphere of radius @p r, 4 pi r^2 [m^2].
inline double sphere_surface_area(double r) {
  return 4.0 * std::numbers::pi * r * r;
}

/// Heat capacity C = m c_p [J/K] of a particle of @p mass [kg] and @p specific_heat [J/(kg K)].
inline double sphere_heat_capacity(double mass, double specific_heat) {
  return mass * specific_heat;
}

/// Largest forward-Euler step for which the particle's new temperature stays a convex combination
/// of old ones (see the file comment): C / sum_j H_ij [s]; infinity for an isolated particle.
/// @param capacity C_i [J/K]; @p total_conductance sum_j H_ij [W/K] (plus h A etc. if used).
inline double thermal_time_step_limit(double capacity, double total_conductance) {
  return total_conductance > 0.0 ? capacity / total_conductance
                                 : std::numeric_limits<double>::infinity();
}

/// dt sum(H) C^-1 of a particle with total conductance sum(H) and inverse heat capacity 1/C: the
/// explicit heat step is stable while this stays <= 1 (see the file comment).
inline double thermal_step_ratio(double dt, double total_conductance, double inverse_capacity) {
  return dt * total_conductance * inverse_capacity;
}

}  // namespace bondem
