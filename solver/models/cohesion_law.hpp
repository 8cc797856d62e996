#pragma once
/// @file cohesion_law.hpp
/// Cohesion of dry surfaces (van der Waals surface energy): the simplified JKR force (`sjkr`) and
/// the Johnson-Kendall-Roberts contact (`jkr`), normal direction only.
///
/// Pure functions: no I/O, no allocation, no state. Sign convention of bond_law.hpp: the component
/// along n_ij (from i to j) of the force on particle i, negative for repulsion, positive for
/// attraction. r* is the effective radius, E* the effective modulus (pair.hpp) and w the work of
/// adhesion [J/m^2] (the case's `surface_energy`), so that the JKR pull-off force is
/// (3/2) pi w r*.
///
/// JKR relations (Johnson, Kendall & Roberts, Proc. R. Soc. Lond. A 324, 301, 1971, whose gamma,
/// the energy per unit contact area, is w; Johnson, "Contact Mechanics", 1985, sec. 5.5 with
/// Delta gamma = w), parametric in the contact radius a, with the load P compressive-positive:
///   P(a)     = 4 E* a^3 / (3 r*) - sqrt(8 pi w E* a^3)
///   delta(a) = a^2 / r* - sqrt(2 pi w a / E*)
/// Lengths of the problem: a_0 = (2 pi w r*^2 / E*)^(1/3), the radius at delta = 0, and
/// delta_0 = a_0^2 / r*. In x = sqrt(a) the overlap relation is the quartic
/// x^4 - c r* x - r* delta = 0, c = sqrt(2 pi w / E*), solved here by Newton from fitted starts,
/// with the closed form (Ferrari) next to the separation point.

#include <cmath>
#include <numbers>

namespace bondem {

/// Simplified JKR cohesion (LIGGGHTS `cohesion sjkr`): the attraction k A of an energy density
/// @p energy_density k [J/m^3] over the contact area A = pi a^2, f . n_ij on i, positive; zero
/// for @p overlap <= 0. A uses the Hertz radius a^2 = r* delta, like every other law of bondem
/// (spot_radius, pair.hpp). LIGGGHTS uses the geometric radius of the lens of two overlapping
/// spheres, a^2 ~ 2 r* delta at small overlap: the same k gives half LIGGGHTS' force here, so a
/// LIGGGHTS cohesionEnergyDensity k_L corresponds to k = 2 k_L.
inline double sjkr_force(double energy_density, double r_star, double overlap) {
  return overlap > 0.0 ? energy_density * std::numbers::pi * r_star * overlap : 0.0;
}

/// Overlap (negative) at which a JKR contact breaks under displacement control: the minimum of
/// delta(a), reached at a_s^3 = pi w r*^2 / (8 E*), is -3 a_s^2 / r* =
/// -(3/4) (pi^2 w^2 r* / E*^2)^(1/3) (from delta(a) of Johnson 1985, sec. 5.5; verified by search
/// in the tests). Zero when w = 0.
inline double jkr_separation_overlap(double r_star, double e_star, double w) {
  const double pi = std::numbers::pi;
  return -0.75 * std::cbrt(pi * pi * w * w * r_star / (e_star * e_star));
}

/// Magnitude of the JKR pull-off force under load control, (3/2) pi w r*, the minimum of P(a)
/// (Johnson, Kendall & Roberts 1971) [N].
inline double jkr_pull_off_force(double r_star, double w) {
  return 1.5 * std::numbers::pi * w * r_star;
}

namespace detail {

/// The real positive root m of m^3 + p m = q for q >= 0 where q^2/4 + p^3/27 >= 0 (one real root
/// by Cardano, or a double negative pair at equality, as at the JKR separation point). With
/// u = cbrt(q/2 + sqrt(q^2/4 + p^3/27)) and v = -p / (3 u), m = u + v; for p >= 0 that sum
/// cancels, so it is formed as q / (u^2 - u v + v^2) (from u^3 + v^3 = q), a sum of positive terms.
inline double cardano_positive_root(double p, double q) {
  // Negative only by round-off next to the double root, where m does not depend on it to first
  // order (d m / d u = 1 - v / u = 0 at u = v).
  const double discriminant = std::fmax(0.25 * q * q + p * p * p / 27.0, 0.0);
  const double u = std::cbrt(0.5 * q + std::sqrt(discriminant));
  const double v = -p / (3.0 * u);
  return p < 0.0 ? u + v : q / (u * u + v * v + p / 3.0);
}

/// Largest root y of y^4 - y - d = 0 for d >= -(3/4) 4^(-1/3) (below, no root; clamped there).
/// Ferrari: (y^2 + m)^2 = 2 m (y + 1/(4 m))^2 when m^3 + d m = 1/8, so
/// y = (sqrt(2 m) + sqrt(sqrt(2 / m) - 2 m)) / 2.
inline double largest_quartic_root_small(double d) {
  // -(3/4) 4^(-1/3): where the two positive roots merge (d y / d d infinite).
  const double d_fold = -0.75 / std::cbrt(4.0);
  const double m = cardano_positive_root(std::fmax(d, d_fold), 0.125);
  // Zero at the fold; round-off must not make it negative.
  const double spread = std::fmax(std::sqrt(2.0 / m) - 2.0 * m, 0.0);
  return 0.5 * (std::sqrt(2.0 * m) + std::sqrt(spread));
}

/// Largest root y of y^4 - y - d = 0 for d >= -0.42 (above the fold at -0.4725): Newton from a
/// degree-4 Chebyshev interpolant of y in s = sqrt(d - d_fold) (y ~ y_fold + const s at the fold,
/// so the interpolant in s stays accurate there; max relative error 5.5e-5 on s in
/// [0, sqrt(1 - d_fold)]). Two steps reach round-off: measured against a long double root,
/// 2.8e-16 relative over d in [-0.42, 1] (7.5e-9 after one). A fixed count keeps it branch-free
/// and the same on every run; below -0.42 f' = 4 y^3 - 1 is too small for two steps.
inline double largest_quartic_root_small_newton(double d) {
  const double s = std::sqrt(d + 0.75 / 1.5874010519681994);  // d - d_fold, 4^(1/3) = 1.5874...
  double y =
      0.63002244409362767 +
      s * (0.64545782372449866 +
           s * (-0.20353290820808111 + s * (0.081096178886726316 + s * -0.017410656750496233)));
  for (int i = 0; i < 2; ++i) {
    const double y2 = y * y;
    y -= (y2 * y2 - y - d) / (4.0 * y2 * y - 1.0);
  }
  return y;
}

/// Largest root y of y^4 - e y - 1 = 0 for 0 <= e <= 1 (y from 1 to 1.2207): Newton from a cubic
/// Chebyshev interpolant in e (max relative error 7.2e-6), two steps: measured 2.0e-16 relative
/// against a long double root (7.8e-11 after one). f' = 4 y^3 - e >= 3, no fold here. At e = 0
/// the start is 1 - 7.2e-6 and the steps land on y = 1 exactly (Hertz).
inline double largest_quartic_root_large_newton(double e) {
  double y = 0.9999927962064976 +
             e * (0.25023804398659969 + e * (-0.032646739903263431 + e * 0.0031576754025178589));
  for (int i = 0; i < 2; ++i) {
    const double y2 = y * y;
    y -= (y2 * y2 - e * y - 1.0) / (4.0 * y2 * y - e);
  }
  return y;
}

}  // namespace detail

/// JKR contact radius a at @p overlap on the stable branch (d a / d delta > 0), for overlap >=
/// jkr_separation_overlap (below it the radius at separation is returned); exactly the Hertz
/// sqrt(r* delta) when w = 0 (and 0 for delta <= 0 then).
/// With x = sqrt(a), x^4 - c r* x - r* delta = 0. For delta > delta_0 the scaling
/// x = (r* delta)^(1/4) y gives y^4 - e y - 1 = 0 with e = (delta_0 / delta)^(3/4) < 1, which
/// reduces to Hertz (y = 1) as w -> 0; below, x = sqrt(a_0) y gives y^4 - y - delta / delta_0 = 0.
/// Both quartics have bounded coefficients, so nothing overflows for any w >= 0. Each is solved
/// by two Newton steps from a fitted start (no cube root above delta_0, one below), except next
/// to the separation point (delta / delta_0 < -0.42), where Newton's derivative vanishes and the
/// closed form (Ferrari) takes over. About 4 times cheaper than the closed form everywhere.
/// Backward stable: the result is the exact radius of an overlap within a few ulps of @p overlap.
/// Near the separation point d a / d delta is infinite, so there its forward error grows like
/// eps delta_0 / (d delta / d a) (about 1e-10 relative at 1e-6 relative distance from a_s).
inline double jkr_contact_radius(double overlap, double r_star, double e_star, double w) {
  // (c r*)^2 = 2 pi w r*^2 / E* = a_0^3
  const double a0_cubed = 2.0 * std::numbers::pi * w * r_star * r_star / e_star;
  if (overlap > 0.0) {
    const double hertz_radius = std::sqrt(r_star * overlap);
    // e^2 = (c r*)^2 / (r* delta)^(3/2) = (delta_0 / delta)^(3/2): e < 1 iff delta > delta_0,
    // decided without the cube root of a_0.
    const double e_squared = a0_cubed / (hertz_radius * hertz_radius * hertz_radius);
    if (e_squared < 1.0) {
      const double y = detail::largest_quartic_root_large_newton(std::sqrt(e_squared));
      return hertz_radius * y * y;
    }
  }
  if (!(a0_cubed > 0.0)) return 0.0;  // w = 0: no contact at delta <= 0
  const double a0 = std::cbrt(a0_cubed);
  const double d = overlap * r_star / (a0 * a0);  // delta / delta_0
  const double y = d >= -0.42 ? detail::largest_quartic_root_small_newton(d)
                              : detail::largest_quartic_root_small(d);
  return a0 * y * y;
}

/// The two parts of the JKR normal force at one contact radius, f . n_ij on particle i.
struct JkrForce {
  double contact_radius;  ///< a [m]
  double elastic;         ///< -4 E* a^3 / (3 r*): the Hertz load of the radius a, repulsion [N]
  double adhesive;        ///< +sqrt(8 pi w E* a^3): the adhesive part, attraction [N]
};

/// The JKR force at @p overlap (>= jkr_separation_overlap) split as the kernel uses it: its damper
/// acts on the elastic part only, then it adds the adhesive part; elastic + adhesive = -P(a).
inline JkrForce jkr_force(double overlap, double r_star, double e_star, double w) {
  const double a = jkr_contact_radius(overlap, r_star, e_star, w);
  const double elastic = -4.0 * e_star * a * a * a / (3.0 * r_star);
  const double adhesive = std::sqrt(8.0 * std::numbers::pi * w * e_star * a) * a;
  return {a, elastic, adhesive};
}

/// Stiffness of a JKR contact of radius @p contact_radius for its damper, 2 E* a, as the Hertz
/// k_con = 2 E* a (hertz_tangent_stiffness, bond_law.hpp) [N/m].
inline double jkr_contact_stiffness(double contact_radius, double e_star) {
  return 2.0 * e_star * contact_radius;
}

/// Energy lost in one quasi-static JKR loading-unloading cycle [J]: loading at zero force until
/// delta = 0, a snap onto the JKR curve, unloading along it to the separation overlap; the loss
/// is integral_{delta_s}^{0} -P d delta, whatever the deepest overlap. In the parameter a,
/// P delta'(a) integrates to F(a) = pi w a_0^2 (16/15 t^(10/3) - 8/3 t^(7/3) + t^(4/3)),
/// t = (a / a_0)^(3/2), between t = 1/4 (separation) and t = 1 (delta = 0):
///   loss = pi w a_0^2 (3/5 + (2/5) 4^(-4/3)) = 0.66300 pi w a_0^2
///        = (3/5 + (2/5) 2^(-8/3)) 2^(2/3) pi^(5/3) (w^5 r*^4 / E*^2)^(1/3)
///        = 7.0920 (w^5 r*^4 / E*^2)^(1/3) = 0.93551 F_pull-off |delta_s|.
/// Derived here from P(a) and delta(a) above. Measured from the zero-load state instead of
/// from delta = 0, the same integral gives 1.5425 F_pull-off |delta_s|, the energy to break a JKR
/// contact at rest, 1.54 F_c delta_c, of Chokshi, Tielens & Hollenbach (ApJ 407, 806, 1993).
inline double jkr_cycle_energy_loss(double r_star, double e_star, double w) {
  const double pi = std::numbers::pi;
  const double a0 = std::cbrt(2.0 * pi * w * r_star * r_star / e_star);
  const double four_to_minus_four_thirds = 0.25 / std::cbrt(4.0);
  return pi * w * a0 * a0 * (0.6 + 0.4 * four_to_minus_four_thirds);
}

}  // namespace bondem
