// The cohesion laws (cohesion_law.hpp) against independent computations: the JKR curve from its
// parametric form in the contact radius a (Johnson, Kendall & Roberts 1971), its extrema found by
// golden-section search, the cycle loss by quadrature, and the Hertz limit.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "solver/models/bond_law.hpp"
#include "solver/models/cohesion_law.hpp"
#include "solver/models/pair.hpp"

namespace bondem {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kEps = 2.220446049250313e-16;

/// One JKR material pair: r* [m], E* [Pa], w [J/m^2].
struct JkrPair {
  double r_star;
  double e_star;
  double w;
};

// A soft cohesive pair (polymer-like, strong adhesion) and a stiff one (metal powder, weak).
constexpr JkrPair kSoft{10e-6, 1e8, 0.05};
constexpr JkrPair kStiff{10e-6, 1e11, 1e-4};
constexpr JkrPair kPairs[] = {kSoft, kStiff};

// The parametric JKR curve, written out independently of the law: P compressive-positive.
double load_of_radius(const JkrPair& p, double a) {
  return 4.0 * p.e_star * a * a * a / (3.0 * p.r_star) -
         std::sqrt(8.0 * kPi * p.w * p.e_star * a * a * a);
}
double overlap_of_radius(const JkrPair& p, double a) {
  return a * a / p.r_star - std::sqrt(2.0 * kPi * p.w * a / p.e_star);
}
double overlap_slope_of_radius(const JkrPair& p, double a) {
  return 2.0 * a / p.r_star - 0.5 * std::sqrt(2.0 * kPi * p.w / (p.e_star * a));
}
// The radius where delta = 0: a^2 / r* = sqrt(2 pi w a / E*), solved by hand.
double radius_at_zero_overlap(const JkrPair& p) {
  return std::cbrt(2.0 * kPi * p.w * p.r_star * p.r_star / p.e_star);
}

/// Argument of the minimum of a unimodal @p f on [lo, hi] by golden-section search. The bracket
/// stops shrinking near sqrt(eps) relative (f is flat there), but the value at it is then within
/// a few eps of the minimum value.
template <class F>
double golden_section_argmin(F f, double lo, double hi) {
  const double ratio = (std::sqrt(5.0) - 1.0) / 2.0;
  double x1 = hi - ratio * (hi - lo);
  double x2 = lo + ratio * (hi - lo);
  double f1 = f(x1);
  double f2 = f(x2);
  for (int i = 0; i < 200; ++i) {
    if (f1 < f2) {
      hi = x2;
      x2 = x1;
      f2 = f1;
      x1 = hi - ratio * (hi - lo);
      f1 = f(x1);
    } else {
      lo = x1;
      x1 = x2;
      f1 = f2;
      x2 = lo + ratio * (hi - lo);
      f2 = f(x2);
    }
  }
  return 0.5 * (lo + hi);
}

/// Composite Simpson rule of @p f on [lo, hi] with @p intervals (even) intervals.
template <class F>
double simpson(F f, double lo, double hi, int intervals) {
  const double h = (hi - lo) / intervals;
  double sum = f(lo) + f(hi);
  for (int i = 1; i < intervals; ++i) sum += (i % 2 == 1 ? 4.0 : 2.0) * f(lo + i * h);
  return sum * h / 3.0;
}

/// Radius at the separation point, the minimum of delta(a), by search (not by the closed form).
double separation_radius(const JkrPair& p) {
  const double a0 = radius_at_zero_overlap(p);
  return golden_section_argmin([&](double a) { return overlap_of_radius(p, a); }, 0.01 * a0, a0);
}

TEST(CohesionSjkr, AttractionIsEnergyDensityTimesHertzArea) {
  const double k = 2.0e5;  // J/m^3
  for (const double overlap : {1e-9, 3e-8, 1e-7}) {
    // pi a^2 with the Hertz a^2 = r* delta, built from spot_radius (pair.hpp) as the other laws do.
    const double a = spot_radius(kSoft.r_star, overlap);
    EXPECT_NEAR(sjkr_force(k, kSoft.r_star, overlap), k * kPi * a * a, 1e-14 * k * kPi * a * a);
    EXPECT_GT(sjkr_force(k, kSoft.r_star, overlap), 0.0);  // attraction in bondem's sign
  }
  EXPECT_EQ(sjkr_force(k, kSoft.r_star, 0.0), 0.0);
  EXPECT_EQ(sjkr_force(k, kSoft.r_star, -1e-8), 0.0);
}

TEST(CohesionSjkr, LiggghtsLensAreaIsTwiceTheHertzArea) {
  // The documented conversion k = 2 k_L: LIGGGHTS' area of the lens of two spheres,
  // A = pi/4 (d-ri-rj)(d+ri-rj)(d-ri+rj)(d+ri+rj) / d^2 (in magnitude), tends to 2 pi r* delta.
  const double ri = 20e-6;
  const double rj = 5e-6;
  const double r_star = effective_radius(ri, rj);
  const double k = 1.0e5;
  for (const double relative_overlap : {1e-4, 1e-6}) {
    const double overlap = relative_overlap * r_star;
    const double d = ri + rj - overlap;
    const double lens =
        kPi / 4.0 * overlap * (d + ri - rj) * (d - ri + rj) * (d + ri + rj) / (d * d);
    // The ratio differs from 2 by O(delta / r): the tolerance is 10 relative_overlap.
    EXPECT_NEAR(k * lens / sjkr_force(k, r_star, overlap), 2.0, 10.0 * relative_overlap);
  }
}

TEST(CohesionJkr, ContactRadiusInvertsTheParametricCurve) {
  for (const JkrPair& p : kPairs) {
    const double a_sep = separation_radius(p);
    // From 1e-5 above the separation radius to 1e4 times it (deep Hertz-like overlaps): both
    // branches of the solver (delta below and above delta_0 = a_0^2 / r*).
    for (double excess = 1e-5; excess < 1e4; excess *= 1.37) {
      const double a = a_sep * (1.0 + excess);
      const double overlap = overlap_of_radius(p, a);
      const double radius = jkr_contact_radius(overlap, p.r_star, p.e_star, p.w);
      // Near the separation point da/ddelta is infinite: the rounding of delta(a) alone moves
      // the root by ~eps delta_0 / delta'(a), ~1e-10 relative at excess 1e-5 (measured 4.4e-11).
      EXPECT_NEAR(radius, a, 1e-10 * a) << "excess " << excess;
      // Backward error: the radius found is the exact one of an overlap within a few ulps of the
      // two terms of delta(a) (delta itself passes through zero).
      const double scale = a * a / p.r_star + std::sqrt(2.0 * kPi * p.w * a / p.e_star);
      EXPECT_NEAR(overlap_of_radius(p, radius), overlap, 8.0 * kEps * scale);
      // The split force: elastic + adhesive = -P(a) in bondem's sign (attraction positive).
      const JkrForce f = jkr_force(overlap, p.r_star, p.e_star, p.w);
      EXPECT_EQ(f.contact_radius, radius);
      EXPECT_LT(f.elastic, 0.0);
      EXPECT_GT(f.adhesive, 0.0);
      const double hertz_part = 4.0 * p.e_star * a * a * a / (3.0 * p.r_star);
      const double adhesive_part = std::sqrt(8.0 * kPi * p.w * p.e_star * a * a * a);
      // a^3 and a^(3/2) carry 3 and 1.5 times the relative error of a.
      EXPECT_NEAR(f.elastic, -hertz_part, 3.1e-10 * hertz_part);
      EXPECT_NEAR(f.adhesive, adhesive_part, 1.6e-10 * adhesive_part);
      EXPECT_NEAR(f.elastic + f.adhesive, -load_of_radius(p, a),
                  3.1e-10 * (hertz_part + adhesive_part));
    }
  }
}

TEST(CohesionJkr, ContactRadiusAtZeroOverlapAndAcrossTheBranchSwitch) {
  for (const JkrPair& p : kPairs) {
    const double a0 = radius_at_zero_overlap(p);
    EXPECT_NEAR(jkr_contact_radius(0.0, p.r_star, p.e_star, p.w), a0, 4.0 * kEps * a0);
    // The solver changes scaling at delta_0 = a_0^2 / r*; both sides agree to round-off.
    const double delta0 = a0 * a0 / p.r_star;
    const double below = jkr_contact_radius(delta0 * (1.0 - 4.0 * kEps), p.r_star, p.e_star, p.w);
    const double above = jkr_contact_radius(delta0 * (1.0 + 4.0 * kEps), p.r_star, p.e_star, p.w);
    EXPECT_NEAR(below, above, 16.0 * kEps * above);
    // Stable branch: the radius grows with the overlap over the whole range.
    double previous = 0.0;
    const double delta_sep = jkr_separation_overlap(p.r_star, p.e_star, p.w);
    for (int i = 0; i <= 1000; ++i) {
      const double overlap = delta_sep + (3.0 * delta0 - delta_sep) * i / 1000.0;
      const double radius = jkr_contact_radius(overlap, p.r_star, p.e_star, p.w);
      EXPECT_GT(radius, previous) << "overlap " << overlap;
      previous = radius;
    }
  }
}

// The radius comes from Newton steps with fitted starts (fixed count, so the fit's worst point
// matters) except next to the separation point (delta < -0.42 delta_0), where the closed form
// takes over. A dense sweep of both pairs checks the backward error everywhere, and the two
// solvers must meet at their switch.
TEST(CohesionJkr, NewtonStepsAreBackwardStableOnADenseSweepAndMeetTheClosedForm) {
  for (const JkrPair& p : kPairs) {
    const double a_sep = separation_radius(p);
    for (double excess = 1e-4; excess < 30.0; excess *= 1.003) {
      const double a = a_sep * (1.0 + excess);
      const double overlap = overlap_of_radius(p, a);
      const double radius = jkr_contact_radius(overlap, p.r_star, p.e_star, p.w);
      const double scale = a * a / p.r_star + std::sqrt(2.0 * kPi * p.w * a / p.e_star);
      ASSERT_NEAR(overlap_of_radius(p, radius), overlap, 8.0 * kEps * scale) << "excess " << excess;
    }
    const double a0 = radius_at_zero_overlap(p);
    const double delta0 = a0 * a0 / p.r_star;
    const double newton =
        jkr_contact_radius(-0.42 * delta0 * (1.0 - kEps), p.r_star, p.e_star, p.w);
    const double closed_form =
        jkr_contact_radius(-0.42 * delta0 * (1.0 + kEps), p.r_star, p.e_star, p.w);
    // d a / d delta is finite there (y = 0.768, f' = 4 y^3 - 1 = 0.81 in the scaled quartic): the
    // overlaps 2 ulps apart move a by ~3 ulps, each solver adds a few.
    EXPECT_NEAR(newton, closed_form, 16.0 * kEps * closed_form);
  }
}

TEST(CohesionJkr, PullOffIsTheLeastLoad) {
  for (const JkrPair& p : kPairs) {
    const double pull_off = jkr_pull_off_force(p.r_star, p.w);
    EXPECT_NEAR(pull_off, 1.5 * kPi * p.w * p.r_star, 1e-15 * pull_off);
    // Load control: the minimum of P(a) over all a (unimodal), searched on the parametric curve.
    const double a0 = radius_at_zero_overlap(p);
    const auto load = [&](double a) { return load_of_radius(p, a); };
    const double a_pull = golden_section_argmin(load, 0.01 * a0, 10.0 * a0);
    // The value at the searched minimum is within a few eps of the true minimum value.
    EXPECT_NEAR(load(a_pull), -pull_off, 1e-13 * pull_off);
    // The same through the law: the largest attraction along the stable branch, searched in delta.
    const double delta_sep = jkr_separation_overlap(p.r_star, p.e_star, p.w);
    const auto repulsion = [&](double overlap) {
      const JkrForce f = jkr_force(overlap, p.r_star, p.e_star, p.w);
      return -(f.elastic + f.adhesive);
    };
    const double delta_pull = golden_section_argmin(repulsion, delta_sep, 0.0);
    EXPECT_NEAR(repulsion(delta_pull), -pull_off, 1e-13 * pull_off);
  }
}

TEST(CohesionJkr, SeparationOverlapIsTheLeastOverlap) {
  for (const JkrPair& p : kPairs) {
    const double delta_sep = jkr_separation_overlap(p.r_star, p.e_star, p.w);
    EXPECT_LT(delta_sep, 0.0);
    // Displacement control: the minimum of delta(a), searched on the parametric curve.
    const double a_sep = separation_radius(p);
    EXPECT_NEAR(overlap_of_radius(p, a_sep), delta_sep, 1e-13 * -delta_sep);
    // The load there: -(5/9) of the pull-off force (P(a_s) = pi w r* / 6 - pi w r* with
    // a_s^3 = pi w r*^2 / (8 E*)). a_s is known only to ~sqrt(eps) relative (delta is flat
    // there) and P is not: 1e-7.
    const double pull_off = jkr_pull_off_force(p.r_star, p.w);
    EXPECT_NEAR(load_of_radius(p, a_sep), -5.0 / 9.0 * pull_off, 1e-7 * pull_off);
    // Through the law at the separation overlap: attraction (5/9) F_pull-off; the radius there is
    // as ill-conditioned, hence the same tolerance.
    const JkrForce f = jkr_force(delta_sep, p.r_star, p.e_star, p.w);
    EXPECT_NEAR(f.contact_radius, a_sep, 1e-7 * a_sep);
    EXPECT_NEAR(f.elastic + f.adhesive, 5.0 / 9.0 * pull_off, 1e-7 * pull_off);
    // Below the separation overlap the law holds the radius at separation (no NaN).
    const JkrForce beyond = jkr_force(1.5 * delta_sep, p.r_star, p.e_star, p.w);
    EXPECT_NEAR(beyond.contact_radius, a_sep, 1e-7 * a_sep);
  }
}

TEST(CohesionJkr, CycleEnergyLossMatchesQuadrature) {
  for (const JkrPair& p : kPairs) {
    const double loss = jkr_cycle_energy_loss(p.r_star, p.e_star, p.w);
    const double a_sep = separation_radius(p);
    const double a0 = radius_at_zero_overlap(p);
    // Unloading from delta = 0 to separation: loss = integral of -P d delta = integral over a of
    // -P(a) delta'(a), smooth in a (powers of sqrt(a), a > 0): Simpson converges like h^4. The
    // searched a_s errs by ~1e-8 relative, but delta'(a_s) = 0 makes that a second-order change.
    const auto integrand = [&](double a) {
      return -load_of_radius(p, a) * overlap_slope_of_radius(p, a);
    };
    EXPECT_NEAR(simpson(integrand, a_sep, a0, 2000), loss, 1e-10 * loss);
    // Through the law: trapezoid in delta of the attraction. The force has a square-root cusp at
    // delta_sep, so the rule converges like h^1.5 (measured 7e-9 relative with 1e5 intervals).
    const double delta_sep = jkr_separation_overlap(p.r_star, p.e_star, p.w);
    const int intervals = 100000;
    const double h = -delta_sep / intervals;
    double sum = 0.0;
    for (int i = 0; i <= intervals; ++i) {
      const JkrForce f = jkr_force(delta_sep + i * h, p.r_star, p.e_star, p.w);
      sum += (i == 0 || i == intervals ? 0.5 : 1.0) * (f.elastic + f.adhesive);
    }
    EXPECT_NEAR(sum * h, loss, 1e-6 * loss);
    // The stated scaling: 7.0922 (w^5 r*^4 / E*^2)^(1/3) for both pairs (printed to 5 digits).
    const double scale =
        std::cbrt(std::pow(p.w, 5) * std::pow(p.r_star, 4) / (p.e_star * p.e_star));
    EXPECT_NEAR(loss / scale, 7.0922, 5e-5);
    // Literature: from the zero-load state (P = 0 at a^3 = 9 pi w r*^2 / (2 E*)) to separation, the
    // energy to break a contact is 1.54 F_c delta_c (Chokshi, Tielens & Hollenbach, ApJ 1993),
    // quoted to 3 digits.
    const double a_rest = std::cbrt(4.5 * kPi * p.w * p.r_star * p.r_star / p.e_star);
    const double breaking = simpson(integrand, a_sep, a_rest, 2000);
    EXPECT_NEAR(breaking / (jkr_pull_off_force(p.r_star, p.w) * -delta_sep), 1.54, 5e-3);
  }
}

TEST(CohesionJkr, WithoutAdhesionIsHertz) {
  const double r_star = kSoft.r_star;
  const double e_star = kSoft.e_star;
  EXPECT_EQ(jkr_separation_overlap(r_star, e_star, 0.0), 0.0);
  EXPECT_EQ(jkr_cycle_energy_loss(r_star, e_star, 0.0), 0.0);
  EXPECT_EQ(jkr_contact_radius(0.0, r_star, e_star, 0.0), 0.0);
  EXPECT_EQ(jkr_contact_radius(-1e-9, r_star, e_star, 0.0), 0.0);
  for (const double overlap : {1e-12, 1e-9, 1e-7, 1e-6}) {
    const double hertz_radius = std::sqrt(r_star * overlap);
    const JkrForce f = jkr_force(overlap, r_star, e_star, 0.0);
    EXPECT_NEAR(f.contact_radius, hertz_radius, 2.0 * kEps * hertz_radius);
    EXPECT_EQ(f.adhesive, 0.0);
    const double hertz = hertz_stiffness(e_star, r_star) * overlap * std::sqrt(overlap);
    EXPECT_NEAR(f.elastic, -hertz, 8.0 * kEps * hertz);
    const double k_con = hertz_tangent_stiffness(e_star, r_star, overlap);
    EXPECT_NEAR(jkr_contact_stiffness(f.contact_radius, e_star), k_con, 4.0 * kEps * k_con);
  }
  // w -> 0 at a fixed overlap: a = a_H (1 + e/2 + O(e^3)) with e = (delta_0 / delta)^(3/4)
  // = sqrt(2 pi w / E*) r* / a_H^(3/2), from y^4 - e y - 1 = 0 expanded to second order
  // (y = 1 + e/4 - e^2/32). The e^3 term of a / a_H is -e^3/64 (mpmath: -0.0155 at e = 0.01).
  const double overlap = 1e-7;
  const double hertz_radius = std::sqrt(r_star * overlap);
  for (double w = 1e-2; w > 1e-30; w *= 1e-2) {
    const double e = std::sqrt(2.0 * kPi * w / e_star) * r_star / std::pow(hertz_radius, 1.5);
    ASSERT_LT(e, 1.0);
    const double radius = jkr_contact_radius(overlap, r_star, e_star, w);
    EXPECT_NEAR(radius / hertz_radius - 1.0, 0.5 * e, 0.02 * e * e * e + 4.0 * kEps) << "w " << w;
  }
}

}  // namespace
}  // namespace bondem
