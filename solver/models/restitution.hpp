#pragma once
/// @file restitution.hpp
/// Coefficient of restitution e <-> contact damping ratio xi_con for the two clamped normal
/// contacts: the damped Hertz law (hertz_contact_force, bond_law.hpp, eq. 26) and the linear law
/// (hooke_contact_force, hooke_law.hpp).
///
/// Pure functions: no I/O, no allocation, no state; closed forms and a bisection, no time stepping.
///
/// The Hertz law, m* delta'' = -k_h delta^(3/2) - 2 xi sqrt(m* k_con) delta', k_con = (3/2) k_h
/// sqrt(delta), is Tsuji's (Tsuji, Tanaka & Ishida, Powder Technol. 71, 239, 1992): a damper
/// alpha sqrt(m* k_h) delta^(1/4) with alpha = 2 sqrt(3/2) xi = sqrt(6) xi. With delta = delta0 x,
/// t = (delta0 / v0) tau and m* v0^2 = k_h delta0^(5/2) it reads
///   x'' = -max(0, x^(3/2) + sqrt(6) xi x^(1/4) x'),  x(0) = 0, x'(0) = 1,
/// so e = -x' at separation depends on xi alone, not on the speed, size or modulus.
///
/// Exact mapping onto the linear law (Antypov & Elliott, "On an analytical solution for the damped
/// Hertzian spring", EPL, 2011; generalised by Feng, arXiv:2603.27764, 2026): with
/// x = (5/4)^(2/5) y^(4/5) the phase-plane equation v dv/dx of the Hertz impact becomes
///   v dv/dy = -y - 2 zeta v,  zeta = sqrt(6/5) xi,
/// which is the linear spring-dashpot's (x'' = -x - 2 zeta x') with the same initial state
/// (y = 0, v = 1). The sign rule maps too: the Hertz total force is (y + 2 zeta v) / (dx/dy) with
/// dx/dy > 0, the linear one's divided by a positive factor, so both laws release the pair at the
/// same point of the common phase portrait, after which v is constant. Hence, exactly, e_hertz(xi)
/// = e_hooke(sqrt(6/5) xi) with the clamped linear restitution of Schwager & Poeschel ("Coefficient
/// of restitution and linear-dashpot model revisited", Granular Matter 9, 465, 2007); the same
/// release-at-zero-force rule for viscoelastic spheres is Schwager & Poeschel, Phys. Rev. E 78,
/// 051304, 2008. Measured against a direct RK4 integration of the dimensional Hertz impact at 0.1
/// to 5 m/s (tests/test_restitution.cpp): agreement to 1e-10, the integration's own error.
///
/// What the clamp changes: the formula of LIGGGHTS and Yade, xi = sqrt(5/6) (-ln e) /
/// sqrt(ln^2 e + pi^2), is exact for the attracting (unclamped) damper, which ends the contact at
/// zero overlap; with bondem's clamp that xi rebounds more: e = 0.5 asked gives 0.5503 (the exact
/// xi is 0.2330, not 0.1967), e = 0.9 gives 0.9020 and e = 0.1 gives 0.2527 (xi 1.135, not 0.540)
/// (tests: RestitutionHertz.UnclampedFormulaIsExactOnlyWithoutTheClamp).
///
/// Range: e decreases strictly from 1 (xi = 0) and stays positive for every finite xi. A clamped
/// contact always lets go: e ~ 1 / (4 zeta^2) = 5 / (24 xi^2) for large xi (the heavily damped pair
/// creeps apart and is released as soon as it starts to slow down), e = exp(-2) = 0.1353 at
/// critical damping zeta = 1 (xi = 0.9129), 1 - e ~ pi sqrt(6/5) xi for small xi. Every 0 < e <= 1
/// has its xi; e = 1e-3 needs xi = 14.35 and e = 1e-6 needs xi = 456, dampers whose time-step limit
/// (damper_time_step, calculator.hpp) is then far below the contact's own.

#include <cmath>
#include <limits>

namespace bondem {

/// Restitution of the clamped linear (hooke) contact for any damping ratio @p xi >= 0: equal to
/// hooke_restitution (hooke_law.hpp) below critical damping, exp(-2 xi arccos(xi) / sqrt(1 -
/// xi^2)), and past it exp(-2 xi arccosh(xi) / sqrt(xi^2 - 1)), where the clamp still releases the
/// pair (Schwager & Poeschel, Granular Matter 9, 465, 2007). NaN for xi < 0.
inline double clamped_linear_restitution(double xi) {
  if (!(xi >= 0.0)) return std::numeric_limits<double>::quiet_NaN();
  if (xi == 1.0) return std::exp(-2.0);  // both branches tend to 2 xi * 1
  // (1 - xi)(1 + xi), not 1 - xi^2: no cancellation next to critical damping.
  const double phase = xi < 1.0 ? std::acos(xi) / std::sqrt((1.0 - xi) * (1.0 + xi))
                                : std::acosh(xi) / std::sqrt((xi - 1.0) * (xi + 1.0));
  return std::exp(-2.0 * xi * phase);
}

/// Restitution of the damped, clamped Hertz contact (hertz_contact_force) with damping ratio
/// @p xi >= 0, whatever the impact speed: the clamped linear restitution at sqrt(6/5) xi (see the
/// file comment). NaN for xi < 0. (calculator.hpp's hertz_restitution integrates the same impact
/// with RK4; this closed form can replace it.)
inline double hertz_restitution(double xi) {
  return clamped_linear_restitution(std::sqrt(6.0 / 5.0) * xi);
}

/// Damping ratio xi >= 0 of the clamped linear (hooke) contact whose restitution
/// (clamped_linear_restitution, which is hooke_restitution below xi = 1) is @p restitution, for
/// 0 < e <= 1: e = 1 gives 0, e < exp(-2) = 0.1353 gives xi > 1. NaN outside (0, 1].
inline double hooke_damping_ratio(double restitution) {
  if (!(restitution > 0.0 && restitution <= 1.0)) return std::numeric_limits<double>::quiet_NaN();
  if (restitution == 1.0) return 0.0;
  // e = exp(-2 g) with g = xi arccos(xi) / sqrt(1 - xi^2) below critical damping and, writing
  // xi = cosh(t) past it, g = t coth(t): g rises from 0 (xi = 0) through 1 (xi = 1) to infinity.
  // Bisection to adjacent doubles (at most ~110 halvings): deterministic, a few microseconds.
  const double target = -0.5 * std::log(restitution);
  if (target <= 1.0) {
    double lo = 0.0;  // g(lo) < target <= g(hi)
    double hi = 1.0;
    for (int i = 0; i < 400; ++i) {
      const double mid = 0.5 * (lo + hi);
      if (mid <= lo || mid >= hi) break;
      // (1 - xi)(1 + xi), not 1 - xi^2: no cancellation next to critical damping.
      const double g = mid * std::acos(mid) / std::sqrt((1.0 - mid) * (1.0 + mid));
      (g < target ? lo : hi) = mid;
    }
    return hi;
  }
  double lo = 0.0;  // t coth(t) >= t: the root lies below target
  double hi = target;
  for (int i = 0; i < 400; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (mid <= lo || mid >= hi) break;
    (mid / std::tanh(mid) < target ? lo : hi) = mid;
  }
  return std::cosh(hi);
}

/// Damping ratio xi >= 0 of the damped, clamped Hertz contact whose restitution is @p restitution,
/// for 0 < e <= 1 (e = 1 gives 0): sqrt(5/6) times the linear law's (see the file comment). NaN
/// outside (0, 1].
inline double hertz_damping_ratio(double restitution) {
  return hooke_damping_ratio(restitution) / std::sqrt(6.0 / 5.0);
}

}  // namespace bondem
