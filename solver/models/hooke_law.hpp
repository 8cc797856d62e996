#pragma once
/// @file hooke_law.hpp
/// Linear spring-dashpot normal contact ("hooke"): f . n_ij = -k delta - 2 xi_con sqrt(m* k)
/// d(delta)/dt, a contact that never attracts and never bonds (no adhesion term).
///
/// Pure functions: no I/O, no allocation, no state. Sign convention of bond_law.hpp: the component
/// along n_ij (from i to j) of the force on particle i, negative for repulsion.

#include <cmath>
#include <limits>
#include <numbers>

#include "solver/models/bond_law.hpp"
#include "solver/models/normal_law.hpp"
#include "solver/models/pair.hpp"
#include "solver/models/restitution.hpp"

namespace bondem {

/// Coefficients of one contact of the linear law; derived once per contact.
struct HookePair {
  double stiffness;  ///< k [N/m]
  double damping;    ///< 2 xi_con sqrt(m* k) [N s/m]
};

/// Damped linear contact with the same sign rule as the damped Hertz term (hertz_contact_force):
/// the total, not the damper alone, is clamped at zero, so a separating pair is never pulled back.
inline double hooke_contact_force(const HookePair& pair, double overlap, double overlap_rate) {
  const double force = -pair.stiffness * overlap - pair.damping * overlap_rate;
  return force > 0.0 ? 0.0 : force;
}

/// The pair of stiffness @p k and effective mass @p m_star with damping ratio @p xi.
inline HookePair make_hooke_pair(double k, double m_star, double xi) {
  return HookePair{k, 2.0 * xi * std::sqrt(m_star * k)};
}

/// Phase pi - theta of the damped oscillation at which the clamped force of an impact with damping
/// ratio 0 <= @p xi < 1 reaches zero and the pair separates: theta = atan2(2 xi s, 1 - 2 xi^2),
/// s = sqrt(1 - xi^2) (Schwager & Poeschel, "Coefficient of restitution and linear-dashpot model
/// revisited", Granular Matter 9, 465, 2007).
inline double hooke_separation_phase(double xi) {
  const double s = std::sqrt(1.0 - xi * xi);
  return std::numbers::pi - std::atan2(2.0 * xi * s, 1.0 - 2.0 * xi * xi);
}

/// Restitution of the clamped linear law, independent of the impact speed, for 0 <= @p xi < 1:
/// exp(-xi / sqrt(1 - xi^2) (pi - theta)). Without the clamp (an attracting damper) it would be
/// exp(-pi xi / sqrt(1 - xi^2)), smaller: the clamp ends the contact at zero force, not at zero
/// overlap.
inline double hooke_restitution(double xi) {
  return std::exp(-xi / std::sqrt(1.0 - xi * xi) * hooke_separation_phase(xi));
}

/// Duration of an impact of the clamped linear law until the overlap is back to zero, for
/// 0 <= @p xi < 1: the phase to separation over omega_d = omega_0 sqrt(1 - xi^2), then a free
/// flight through the remaining overlap, sin(theta) / omega_d. pi / omega_0 when undamped.
inline double hooke_contact_time(double k, double m_star, double xi) {
  const double omega_d = std::sqrt(k / m_star) * std::sqrt(1.0 - xi * xi);
  const double s = std::sqrt(1.0 - xi * xi);
  const double sin_theta = 2.0 * xi * s;  // sin(atan2(2 xi s, 1 - 2 xi^2)), the radius being 1
  return (hooke_separation_phase(xi) + sin_theta) / omega_d;
}

/// Run-wide parameters of the linear law (`contact: {normal_law: hooke, stiffness: k}`).
struct HookeLawSpec {
  double stiffness = 0.0;  ///< k [N/m], the same for every pair and wall contact

  /// Calls @p visit(name, value) for each parameter (the case fingerprint covers them all).
  template <class Visit>
  void parameters(Visit&& visit) const {
    visit("stiffness", stiffness);
  }
};

/// The linear law as the kernels' normal-force law (normal_law.hpp). It has no adhesion: force()
/// ignores the bond criterion and never reports a bond (the reader refuses a `bond:` block).
struct HookeNormalLaw {
  using Pair = HookePair;
  double stiffness;  ///< k [N/m]

  /// A pair of effective mass m*; a particle on a wall or tool has m* = m, and the same k.
  Pair pair(const PairCoefficients& c, double /*r_star*/, double m_star) const {
    return make_hooke_pair(stiffness, m_star, c.contact_damping);
  }
  NormalForce force(const Pair& pair, double overlap, double overlap_rate,
                    bool /*criterion_met*/) const {
    return {hooke_contact_force(pair, overlap, overlap_rate), false};
  }
  /// A contact never attracts: its load is the repulsion itself.
  double friction_load(const Pair& /*pair*/, const NormalForce& f, double /*overlap*/) const {
    return f.force < 0.0 ? -f.force : 0.0;
  }
  /// The spring k, whatever the contact radius [N/m].
  double normal_stiffness(const PairCoefficients& /*c*/, double /*contact_radius*/) const {
    return stiffness;
  }
  /// xi_con of the clamped linear contact whose restitution is @p restitution (restitution.hpp).
  static double damping_ratio_for(double restitution) { return hooke_damping_ratio(restitution); }
  /// Restitution of the clamped linear contact with damping ratio @p xi.
  static double restitution_for(double xi) { return clamped_linear_restitution(xi); }

  /// The undamped impact at @p impact_speed: contact time pi sqrt(m*/k) whatever the speed, as the
  /// Hertz law reports its undamped impact (the damper's own limit is contact_damping's). Not
  /// static, unlike the bond law's: k is a run-wide parameter of the law object, not of the pair.
  NormalTimeScales time_scales(const PairCoefficients& c, double /*r_star*/, double m_star,
                               double impact_speed, bool /*bonding*/) const {
    NormalTimeScales s{};
    s.impact = "a linear (hooke) impact";
    s.impact_overlap = impact_speed * std::sqrt(m_star / stiffness);
    s.contact_time = std::numbers::pi * std::sqrt(m_star / stiffness);
    s.contact_stiffness = stiffness;
    s.contact_damping = c.contact_damping;
    // Never bonds: no bond oscillation, so the bond damper sets no limit.
    s.oscillation_stiffness = 0.0;
    s.oscillation_damping = 0.0;
    s.oscillation_period = std::numeric_limits<double>::infinity();
    return s;
  }
};

}  // namespace bondem
