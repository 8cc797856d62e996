#pragma once
/// @file normal_law.hpp
/// What a normal-force law gives the kernels and the time-step rule (the concept; laws are
/// registered in normal_laws.hpp).
///
/// A normal-force law is a small copyable object (its run-wide parameters, e.g. an adhesion
/// exponent) with const, pure member functions; `Pair` is its per-contact coefficient type:
///   Pair pair(const PairCoefficients&, double r_star, double m_star)      coefficients of a pair
///   Pair surface_pair(const PairCoefficients&, double radius, double mass) of a particle on a wall
///   NormalForce force(const Pair&, double overlap, double overlap_rate, bool criterion_met)
///   double surface_force(const Pair&, double overlap, double overlap_rate)  f . n_ij, never bonds
///   double friction_load(const Pair&, const NormalForce&, double overlap)  load for Coulomb
///   double surface_friction_load(double surface_force)
///   NormalTimeScales time_scales(const PairCoefficients&, double r_star, double m_star,
///                                double impact_speed, bool bonding) const  (or static)
/// and its Spec (the run-wide parameters held in Case::normal_law) lists them for the case
/// fingerprint: template <class F> void parameters(F&& f) const, calling f("name", value).
/// Forces follow bond_law.hpp's convention: the component along n_ij (from i to j) of the force on
/// i, negative for repulsion.

#include <limits>

namespace bondem {

/// What the time-step rule needs of a law for one pair (or a particle on a wall: r* = r, m* = m),
/// so that the rule has no branch per law.
struct NormalTimeScales {
  const char* impact;            ///< what the impact is, for messages ("a Hertz impact")
  double impact_overlap;         ///< largest overlap of an undamped impact at the speed [m]
  double contact_time;           ///< duration of that impact [s]
  double contact_stiffness;      ///< stiffest tangent stiffness of that impact [N/m]
  double contact_damping;        ///< damping ratio of the contact damper
  double oscillation_stiffness;  ///< tangent stiffness of a bonded pair at rest [N/m]
  double oscillation_damping;    ///< damping ratio of the bond damper
  /// Period of small oscillations of a bonded pair [s]; infinite when the pair cannot bond, and
  /// then the bond damper sets no time-step limit.
  double oscillation_period = std::numeric_limits<double>::infinity();
};

}  // namespace bondem
