#pragma once
/// @file bond_normal_law.hpp
/// The Hertz + adhesion bond law (bond_law.hpp) as the kernels' normal-force law (normal_law.hpp).

#include <cmath>
#include <limits>
#include <numbers>

#include "solver/models/bond_law.hpp"
#include "solver/models/normal_law.hpp"
#include "solver/models/pair.hpp"
#include "solver/models/restitution.hpp"

namespace bondem {

/// Run-wide parameters of the Hertz + bond law: none (every bond parameter is the material
/// pair's, PairCoefficients).
struct BondLawSpec {
  /// Calls @p visit(name, value) for each parameter (the case fingerprint covers them all).
  template <class Visit>
  void parameters(Visit&& /*visit*/) const {}
};

/// Hertz contact (eq. 26) and, past delta_crit where the criterion holds, the bond (eq. 15, 22-25).
/// The adhesion exponent is the pair's: alpha_adh = 1 takes the branch without std::pow.
struct BondNormalLaw {
  using Pair = BondPair;

  Pair pair(const PairCoefficients& c, double r_star, double m_star) const {
    return make_bond_pair(c, r_star, m_star);
  }
  NormalForce force(const Pair& pair, double overlap, double overlap_rate,
                    bool criterion_met) const {
    if (!(criterion_met && overlap > pair.critical_overlap)) {
      return {hertz_contact_force(pair, overlap, overlap_rate), false};
    }
    // Eq. 25's adhesive branch (normal_force), its test already made.
    return {pair.alpha == 1.0
                ? bond_force(pair, LinearAdhesion{}, overlap, overlap_rate)
                : bond_force(pair, GeneralAdhesion{pair.alpha}, overlap, overlap_rate),
            true};
  }
  double friction_load(const Pair& pair, const NormalForce& f, double overlap) const {
    return bondem::friction_load(pair, f, overlap);
  }
  /// Tangent stiffness of the Hertz contact, 2 E* a, at contact radius @p contact_radius [N/m].
  double normal_stiffness(const PairCoefficients& c, double contact_radius) const {
    return 2.0 * c.effective_modulus * contact_radius;
  }
  /// xi_con of the damped Hertz contact whose restitution is @p restitution (restitution.hpp).
  static double damping_ratio_for(double restitution) { return hertz_damping_ratio(restitution); }
  /// Restitution of the damped Hertz contact with damping ratio @p xi.
  static double restitution_for(double xi) { return hertz_restitution(xi); }

  /// Hertz impact at @p impact_speed (eq. 20) and, when @p bonding, the small oscillations of a
  /// bond about delta_eq (eq. 24).
  static NormalTimeScales time_scales(const PairCoefficients& c, double r_star, double m_star,
                                      double impact_speed, bool bonding) {
    const BondPair pair = make_bond_pair(c, r_star, m_star);
    const double e_star = c.effective_modulus;
    NormalTimeScales s{};
    s.impact = "a Hertz impact";
    s.impact_overlap = hertz_max_overlap(e_star, r_star, m_star, impact_speed);
    s.contact_time = hertz_contact_time(e_star, r_star, m_star, impact_speed);
    // Damping drives the overlap less deep than the undamped maximum: its stiffness is the most a
    // contact at the speed reaches.
    s.contact_stiffness = hertz_tangent_stiffness(e_star, r_star, s.impact_overlap);
    s.contact_damping = c.contact_damping;
    s.oscillation_stiffness = bond_tangent_stiffness(
        e_star, r_star, c.alpha, pair.adhesion_stiffness, pair.equilibrium_overlap);
    s.oscillation_damping = c.bond_damping;
    s.oscillation_period =
        bonding ? 2.0 * std::numbers::pi * std::sqrt(m_star / s.oscillation_stiffness)
                : std::numeric_limits<double>::infinity();
    return s;
  }
};

}  // namespace bondem
