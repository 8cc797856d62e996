// Restitution <-> damping ratio of the clamped Hertz and linear contacts (restitution.hpp). The
// closed forms are checked against impacts integrated directly with the laws' own force functions
// (hertz_contact_force, hooke_contact_force) in SI units, and against the limits of weak and strong
// damping derived from the Hertz equation itself, not from the mapping onto the linear law.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <numbers>

#include "solver/models/bond_law.hpp"
#include "solver/models/hooke_law.hpp"
#include "solver/models/restitution.hpp"

namespace bondem {
namespace {

// Two steel spheres (7850 kg/m^3) of radius 20 um, so r* = 1e-5 m, with E* = 1 GPa.
constexpr double kEStar = 1e9;
constexpr double kRStar = 1e-5;
constexpr double kSphereMass = 7850.0 * 4.0 / 3.0 * std::numbers::pi * 2e-5 * 2e-5 * 2e-5;
constexpr double kMStar = 0.5 * kSphereMass;
// RK4 steps per undamped Hertz contact time in the dimensional impacts.
constexpr double kStepsPerContact = 20000.0;

BondPair hertz_pair(double xi) {
  BondPair pair{};
  pair.hertz_stiffness = 4.0 / 3.0 * kEStar * std::sqrt(kRStar);
  pair.effective_mass = kMStar;
  pair.contact_damping = xi;
  return pair;
}

/// Rebound over impact speed of a head-on impact at @p speed, integrated with RK4 on
/// m* delta'' = force(delta, delta') (force on i along n_ij, so negative decelerates the approach)
/// from first touch (delta = 0 counts as touching: a dashpot acts from the first instant) until
/// the overlap is gone; out of contact there is no force, as in the kernels. The Hertz damper goes
/// as delta^(1/4) ~ t^(1/4): uniform steps from t = 0 would leave an error ~ dt^(5/4) from the
/// first step alone (1e-6 here), so the step grows in proportion to t (1/50 of it, from 1e-8 dt)
/// until it reaches @p dt at t = 50 dt, where the remaining error is ~ dt^4 t^(-11/4), below 1e-10.
template <class Force>
double measured_restitution(Force force, double m_star, double speed, double dt) {
  const auto acceleration = [&](double overlap, double rate) {
    return overlap >= 0.0 ? force(overlap, rate) / m_star : 0.0;
  };
  double x = 0.0;
  double v = speed;
  double t = 0.0;
  for (int n = 0; n < 100 * static_cast<int>(kStepsPerContact); ++n) {
    const double h = std::min(dt, std::max(1e-8 * dt, t / 50.0));
    const double k1x = v;
    const double k1v = acceleration(x, v);
    const double k2x = v + 0.5 * h * k1v;
    const double k2v = acceleration(x + 0.5 * h * k1x, k2x);
    const double k3x = v + 0.5 * h * k2v;
    const double k3v = acceleration(x + 0.5 * h * k2x, k3x);
    const double k4x = v + h * k3v;
    const double k4v = acceleration(x + h * k3x, k4x);
    x += h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
    v += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
    t += h;
    if (x < 0.0) return -v / speed;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

double measured_hertz_restitution(double xi, double speed) {
  const BondPair pair = hertz_pair(xi);
  const double dt = hertz_contact_time(kEStar, kRStar, kMStar, speed) / kStepsPerContact;
  return measured_restitution(
      [&pair](double overlap, double rate) { return hertz_contact_force(pair, overlap, rate); },
      kMStar, speed, dt);
}

TEST(RestitutionHertz, ElasticWithoutDamping) {
  EXPECT_EQ(hertz_restitution(0.0), 1.0);
  EXPECT_EQ(hertz_damping_ratio(1.0), 0.0);
  EXPECT_EQ(hooke_damping_ratio(1.0), 0.0);
  EXPECT_EQ(clamped_linear_restitution(0.0), 1.0);
}

TEST(RestitutionHertz, RoundTrip) {
  // Bisection to adjacent doubles: only round-off in acos / log / exp separates e from itself.
  for (double e : {1e-6, 1e-3, 0.05, 0.1, 0.3, 0.5, 0.7, 0.9, 0.99, 0.999999, 1.0}) {
    const double xi = hertz_damping_ratio(e);
    EXPECT_GE(xi, 0.0) << e;
    EXPECT_NEAR(hertz_restitution(xi), e, 1e-13 * e) << e;
  }
  // Critical damping of the mapped linear law, zeta = sqrt(6/5) xi = 1, is e = exp(-2).
  EXPECT_NEAR(hertz_damping_ratio(std::exp(-2.0)), std::sqrt(5.0 / 6.0), 1e-12);
}

TEST(RestitutionHertz, DecreasesStrictlyAndStaysPositive) {
  // Through critical damping (xi = 0.9129) and far past it: a clamped contact always lets go.
  double previous = hertz_restitution(0.0);
  for (double xi = 1e-4; xi < 2e3; xi *= 1.1) {
    const double e = hertz_restitution(xi);
    EXPECT_LT(e, previous) << xi;
    EXPECT_GT(e, 0.0) << xi;
    previous = e;
  }
  EXPECT_TRUE(std::isnan(hertz_restitution(-0.1)));
  EXPECT_TRUE(std::isnan(hertz_damping_ratio(0.0)));
  EXPECT_TRUE(std::isnan(hertz_damping_ratio(1.5)));
  EXPECT_TRUE(std::isnan(hertz_damping_ratio(std::numeric_limits<double>::quiet_NaN())));
}

TEST(RestitutionHertz, WeakAndStrongDampingLimits) {
  // Weak damping: the energy the damper takes along the undamped trajectory (1/2 v^2 + 2/5 x^(5/2)
  // = 1/2 in the file comment's units), W = 2 sqrt(6) xi int_0^xmax x^(1/4) sqrt(1 - 4/5 x^(5/2))
  // dx = pi sqrt(6/5) xi (a Beta integral), and e = sqrt(1 - 2 W) ~ 1 - W. The next order is
  // ~2 xi relative, so 1e-4 at xi = 1e-5.
  for (double xi : {1e-6, 1e-5}) {
    const double slope = (1.0 - hertz_restitution(xi)) / xi;
    EXPECT_NEAR(slope, std::numbers::pi * std::sqrt(1.2), 1e-4 * slope) << xi;
  }
  // Strong damping: the approach stops at x^(5/4) = 5 / (4 sqrt(6) xi) with the spring negligible;
  // the pair then creeps out at the speed where spring and damper balance, x^(5/4) / (sqrt(6) xi),
  // and is released there: e = 5 / (24 xi^2). Corrections ~ln(xi) / xi^2: 1e-7 at xi = 1e4.
  for (double xi : {3e3, 1e4}) {
    EXPECT_NEAR(hertz_restitution(xi), 5.0 / (24.0 * xi * xi), 1e-6 * 5.0 / (24.0 * xi * xi)) << xi;
  }
}

TEST(RestitutionHertz, MatchesDimensionalImpact) {
  // RK4 with 20000 steps per contact and the graded start: measured deviations are below 1e-10
  // (3e-10 relative; the clamp's kink costs ~ dt^2 F', the rest ~ dt^4), so 1e-8 relative leaves
  // margin and still sees any speed dependence or a wrong factor in the mapping.
  for (double xi : {0.02, 0.2, 0.5, std::sqrt(5.0 / 6.0), 2.0}) {
    const double expected = hertz_restitution(xi);
    for (double speed : {0.1, 1.0, 5.0}) {
      EXPECT_NEAR(measured_hertz_restitution(xi, speed), expected, 1e-8 * expected)
          << "xi " << xi << " speed " << speed;
    }
  }
  // And the inverse, as a case file would use it: ask for e, measure e.
  for (double e : {0.1, 0.5, 0.9}) {
    EXPECT_NEAR(measured_hertz_restitution(hertz_damping_ratio(e), 1.0), e, 1e-8 * e) << e;
  }
}

TEST(RestitutionHertz, UnclampedFormulaIsExactOnlyWithoutTheClamp) {
  // xi = sqrt(5/6) (-ln e) / sqrt(ln^2 e + pi^2) (LIGGGHTS, Yade) is exact for an attracting damper
  // (Antypov & Elliott 2011), too little damping for bondem's clamped law: it rebounds with the
  // restitution quoted in restitution.hpp.
  const double dt = hertz_contact_time(kEStar, kRStar, kMStar, 1.0) / kStepsPerContact;
  const double asked[] = {0.1, 0.5, 0.9};
  const double clamped[] = {0.2527, 0.5503, 0.9020};
  for (int i = 0; i < 3; ++i) {
    const double e = asked[i];
    const double log_e = std::log(e);
    const double xi = std::sqrt(5.0 / 6.0) * -log_e / std::hypot(log_e, std::numbers::pi);
    const BondPair pair = hertz_pair(xi);
    const auto unclamped = [&pair](double overlap, double rate) {
      const double stiffness = 1.5 * pair.hertz_stiffness * std::sqrt(overlap);
      return -pair.hertz_stiffness * overlap * std::sqrt(overlap) -
             2.0 * pair.contact_damping * std::sqrt(pair.effective_mass * stiffness) * rate;
    };
    // This contact ends at zero overlap, where the x^(1/4) damper is singular again: the last step
    // errs by ~ dt^(5/4), measured 1e-7 to 4e-7.
    EXPECT_NEAR(measured_restitution(unclamped, kMStar, 1.0, dt), e, 2e-6) << e;
    EXPECT_NEAR(measured_hertz_restitution(xi, 1.0), clamped[i], 1e-4) << e;
    EXPECT_NEAR(hertz_restitution(xi), clamped[i], 1e-4) << e;
    EXPECT_GT(hertz_damping_ratio(e), xi) << e;
  }
}

TEST(RestitutionHooke, RoundTripWithHookeRestitution) {
  // Below critical damping the closed form is hooke_restitution's (another arithmetic path).
  for (double xi : {0.0, 0.01, 0.3, 0.6, 0.9, 0.999}) {
    EXPECT_NEAR(clamped_linear_restitution(xi), hooke_restitution(xi), 1e-14) << xi;
  }
  for (double e : {0.14, 0.3, 0.5, 0.7, 0.9, 0.99, 1.0}) {
    const double xi = hooke_damping_ratio(e);
    EXPECT_LT(xi, 1.0) << e;  // e > exp(-2) = 0.1353 is underdamped
    EXPECT_NEAR(hooke_restitution(xi), e, 1e-13 * e) << e;
  }
  // Past critical damping (e < exp(-2)) only the extended form applies.
  for (double e : {1e-6, 0.01, 0.1, 0.135}) {
    const double xi = hooke_damping_ratio(e);
    EXPECT_GT(xi, 1.0) << e;
    EXPECT_NEAR(clamped_linear_restitution(xi), e, 1e-13 * e) << e;
  }
  // Both branches meet at critical damping.
  EXPECT_NEAR(clamped_linear_restitution(1.0 - 1e-9), std::exp(-2.0), 1e-8);
  EXPECT_NEAR(clamped_linear_restitution(1.0 + 1e-9), std::exp(-2.0), 1e-8);
  EXPECT_TRUE(std::isnan(hooke_damping_ratio(-0.5)));
}

TEST(RestitutionHooke, OverdampedBranchMatchesDimensionalImpact) {
  // The linear law integrated directly, under and past critical damping: smooth but for the clamp's
  // kink (~ dt^2 F'); measured deviations below 1e-10, so 1e-8.
  const double k = 1e4;
  const double m_star = 1e-4;
  const double dt = std::numbers::pi * std::sqrt(m_star / k) / kStepsPerContact;
  for (double xi : {0.5, 1.0, 1.5, 4.0}) {
    const HookePair pair = make_hooke_pair(k, m_star, xi);
    const auto force = [&pair](double overlap, double rate) {
      return hooke_contact_force(pair, overlap, rate);
    };
    for (double speed : {0.1, 5.0}) {
      EXPECT_NEAR(measured_restitution(force, m_star, speed, dt), clamped_linear_restitution(xi),
                  1e-8)
          << "xi " << xi << " speed " << speed;
    }
  }
}

}  // namespace
}  // namespace bondem
