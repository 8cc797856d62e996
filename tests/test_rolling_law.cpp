// The elastic-plastic spring-dashpot rolling law (EPSD, Ai et al. 2011 model type C) at hand
// values, through its elastic, plastic and unloading branches, and as the one torque on a sphere
// on a flat whose rocking is integrated here: period and log decrement against the closed forms of
// the damped oscillator I_r theta'' + C_r theta' + k_r theta = 0.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "solver/models/rolling_law.hpp"

namespace bondem {
namespace {

using Eigen::Vector3d;

constexpr double kInfinity = std::numeric_limits<double>::infinity();

TEST(RollingEpsd, CoefficientsAtHandValues) {
  // 2.25 k_n mu_r^2 r*^2 with k_n = 1e4 N/m, mu_r = 0.1, r* = 1 mm.
  EXPECT_NEAR(epsd_rolling_stiffness(1.0e4, 0.1, 1.0e-3), 2.25e-4, 1e-15 * 2.25e-4);
  EXPECT_EQ(epsd_rolling_stiffness(1.0e4, 0.0, 1.0e-3), 0.0);
  // 2 eta sqrt(I k) = 2 * 0.3 * sqrt(2 * 8) = 2.4.
  EXPECT_DOUBLE_EQ(epsd_rolling_damping(0.3, 2.0, 8.0), 2.4);
  EXPECT_EQ(epsd_rolling_damping(0.0, 2.0, 8.0), 0.0);
}

TEST(RollingInertia, TwoSpheresAndWallPartner) {
  const double m = 1.0e-5;
  const double r = 1.0e-3;
  const double inertia = 0.4 * m * r * r;
  const double about_contact = inertia + m * r * r;  // 7/5 m r^2, parallel axis
  // Two equal spheres: the harmonic half.
  EXPECT_NEAR(rolling_inertia(inertia, m, r, inertia, m, r), 0.5 * about_contact,
              1e-15 * about_contact);
  // Unequal: 1 / (1/a + 1/b) by hand, b for a sphere of twice the radius (8 m, I = 2/5 8 m 4 r^2).
  const double big = 0.4 * 8.0 * m * 4.0 * r * r + 8.0 * m * 4.0 * r * r;
  EXPECT_NEAR(rolling_inertia(inertia, m, r, 0.4 * 8.0 * m * 4.0 * r * r, 8.0 * m, 2.0 * r),
              about_contact * big / (about_contact + big), 1e-15 * about_contact);
  // A wall (infinite inertia and mass) leaves I_i + m_i r_i^2 exactly, whatever its radius,
  // zero included (inf * 0 would be NaN without the explicit wall branch), on either side.
  EXPECT_EQ(rolling_inertia(inertia, m, r, kInfinity, kInfinity, 0.0), about_contact);
  EXPECT_EQ(rolling_inertia(inertia, m, r, kInfinity, kInfinity, 5.0), about_contact);
  EXPECT_EQ(rolling_inertia(kInfinity, kInfinity, 0.0, inertia, m, r), about_contact);
  EXPECT_EQ(rolling_inertia(inertia, m, r, kInfinity, 1.0, 0.0), about_contact);
}

// Binary-exact inputs: k_r = 2, spin 1/64 rad/s, dt = 1/16 s, so every increment k_r omega dt =
// 2^-9 and every partial sum below is exact; the law must give -k_r theta to the last bit.
constexpr double kStiffness = 2.0;
constexpr double kDt = 1.0 / 16.0;
constexpr double kSpin = 1.0 / 64.0;
constexpr double kDamping = 0.5;
const Vector3d kNormal = Vector3d::UnitZ();

TEST(RollingEpsd, ElasticSpringAccumulatesLinearly) {
  const Vector3d spin = kSpin * Vector3d::UnitX();
  Vector3d spring = Vector3d::Zero();
  const double limit = 1.0;  // reached after 512 steps
  for (int n = 1; n <= 50; ++n) {
    const RollingSpringTorque r =
        epsd_rolling_torque(kStiffness, kDamping, limit, kNormal, spring, spin, kDt);
    spring = r.spring;
    const double theta = n * kSpin * kDt;
    ASSERT_FALSE(r.plastic) << n;
    ASSERT_EQ(r.spring, Vector3d(-kStiffness * theta, 0.0, 0.0)) << n;
    // The damper opposes the spin on top of the spring.
    ASSERT_EQ(r.torque, Vector3d(-kStiffness * theta - kDamping * kSpin, 0.0, 0.0)) << n;
  }
}

TEST(RollingEpsd, PlasticLimitCapsTorqueAndSwitchesDamperOff) {
  // Spin in an oblique tangent direction, so the cap is checked on a vector, not one component.
  // Unit spin: k_r omega dt = 0.125 per step.
  const Vector3d direction = Vector3d(3.0, -4.0, 0.0) / 5.0;
  const double limit = 0.3;  // not a multiple of the increment: the step past it is cut back
  Vector3d spring = Vector3d::Zero();
  int first_plastic = 0;
  for (int n = 1; n <= 10; ++n) {
    const RollingSpringTorque r =
        epsd_rolling_torque(kStiffness, kDamping, limit, kNormal, spring, direction, kDt);
    spring = r.spring;
    if (r.plastic && first_plastic == 0) first_plastic = n;
    if (!r.plastic) continue;
    EXPECT_NEAR(r.torque.norm(), limit, 1e-15) << n;
    // Exactly against the rotation: unit torque = -unit spin.
    EXPECT_NEAR((r.torque / limit + direction).norm(), 0.0, 1e-15) << n;
    EXPECT_EQ(r.torque, r.spring) << n;  // damper off (f = 0) although C_r > 0
  }
  // 2 increments of 0.125 stay below 0.3, the third (0.375) is the first beyond it.
  EXPECT_EQ(first_plastic, 3);
}

TEST(RollingEpsd, UnloadingFromTheLimitIsElastic) {
  const Vector3d forward = Vector3d::UnitY();  // k_r omega dt = 0.125 per step
  const double limit = 0.3;
  Vector3d spring = Vector3d::Zero();
  for (int n = 0; n < 6; ++n) {
    spring = epsd_rolling_torque(kStiffness, kDamping, limit, kNormal, spring, forward, kDt).spring;
  }
  EXPECT_NEAR(spring.y(), -limit, 1e-16);  // at the plastic limit after 0.75 of loading
  // Reverse: the spring unloads from -M_m along the elastic slope, not from the loading path
  // (which would be -0.75 + 0.125 n): -0.3 + 0.125 n, and the damper is back.
  for (int n = 1; n <= 4; ++n) {
    const RollingSpringTorque r =
        epsd_rolling_torque(kStiffness, kDamping, limit, kNormal, spring, -forward, kDt);
    spring = r.spring;
    ASSERT_FALSE(r.plastic) << n;
    EXPECT_NEAR(r.spring.y(), -limit + 0.125 * n, 1e-15) << n;
    EXPECT_NEAR(r.torque.y(), -limit + 0.125 * n + kDamping, 1e-15) << n;
  }
  // 4 reverse steps: +0.2, within the limit on the other side; a fifth reaches +0.325 > 0.3.
  const RollingSpringTorque r =
      epsd_rolling_torque(kStiffness, kDamping, limit, kNormal, spring, -forward, kDt);
  EXPECT_TRUE(r.plastic);
  EXPECT_NEAR(r.torque.y(), limit, 1e-16);
}

TEST(RollingEpsd, TwistAboutTheNormalGivesNoRollingTorque) {
  const Vector3d normal = Vector3d(1.0, 2.0, 2.0) / 3.0;
  const RollingSpringTorque twist =
      epsd_rolling_torque(kStiffness, kDamping, 1.0, normal, Vector3d::Zero(), 5.0 * normal, kDt);
  EXPECT_NEAR(twist.torque.norm(), 0.0, 1e-15);
  EXPECT_NEAR(twist.spring.norm(), 0.0, 1e-15);
  EXPECT_FALSE(twist.plastic);
  // Twist added to a rolling spin changes nothing: only the tangential part counts.
  const Vector3d rolling = Vector3d(2.0, -1.0, 0.0) / 64.0;  // perpendicular to the normal
  const RollingSpringTorque plain =
      epsd_rolling_torque(kStiffness, kDamping, 1.0, normal, Vector3d::Zero(), rolling, kDt);
  const RollingSpringTorque mixed = epsd_rolling_torque(
      kStiffness, kDamping, 1.0, normal, Vector3d::Zero(), rolling + 5.0 * normal, kDt);
  EXPECT_NEAR((mixed.torque - plain.torque).norm(), 0.0, 1e-15);
  EXPECT_NEAR((mixed.spring - plain.spring).norm(), 0.0, 1e-15);
  EXPECT_GT(plain.torque.norm(), 0.0);
}

TEST(RollingEpsd, StoredSpringFollowsTheRotatingContact) {
  // The contact normal turned by 0.1 rad about y: the stored spring is brought back into the new
  // tangent plane with its length kept, so no spin leaves it unchanged up to that rotation.
  const Vector3d spring(0.2, 0.0, 0.0);
  const double a = 0.1;
  const Vector3d normal(std::sin(a), 0.0, std::cos(a));
  const RollingSpringTorque r =
      epsd_rolling_torque(kStiffness, kDamping, 1.0, normal, spring, Vector3d::Zero(), kDt);
  EXPECT_NEAR(r.spring.dot(normal), 0.0, 1e-16);
  EXPECT_NEAR(r.spring.norm(), 0.2, 1e-16);
  EXPECT_NEAR(r.spring.x(), 0.2 * std::cos(a), 1e-16);
  EXPECT_NEAR(r.spring.z(), -0.2 * std::sin(a), 1e-16);
}

// A sphere rocking on a flat under the EPSD torque alone: the rotation theta about x obeys
// I_r theta'' = M (the flat has no spin, I_r = 7/5 m r^2 by the wall branch of rolling_inertia).
// Symplectic Euler as the kernel steps: theta and the spring advance with the old spin, then the
// spin with the torque. Returns theta at every step.
struct Rocking {
  double dt;
  double period;  // 2 pi sqrt(I_r / k_r)
  std::vector<double> theta;
};

Rocking rock(double damping_ratio, int steps_per_period, int periods) {
  const double m = 1.0e-5;
  const double r = 1.0e-3;
  const double inertia = rolling_inertia(0.4 * m * r * r, m, r, kInfinity, kInfinity, 0.0);
  const double k_r = epsd_rolling_stiffness(1.0e4, 0.1, r);
  const double c_r = epsd_rolling_damping(damping_ratio, inertia, k_r);
  const double limit = 0.1 * r * m * 9.81;  // mu_r r* F_n under its weight
  const double omega_0 = std::sqrt(k_r / inertia);
  Rocking out{};
  out.period = 2.0 * std::numbers::pi / omega_0;
  out.dt = out.period / steps_per_period;
  // Amplitude a tenth of the elastic range limit / k_r: the spring never reaches the limit.
  double spin = 0.1 * limit / k_r * omega_0;
  double theta = 0.0;
  Vector3d spring = Vector3d::Zero();
  for (int n = 0; n < steps_per_period * periods; ++n) {
    const RollingSpringTorque t = epsd_rolling_torque(k_r, c_r, limit, Vector3d::UnitZ(), spring,
                                                      spin * Vector3d::UnitX(), out.dt);
    EXPECT_FALSE(t.plastic);
    spring = t.spring;
    theta += spin * out.dt;
    spin += t.torque.x() / inertia * out.dt;
    out.theta.push_back(theta);
  }
  return out;
}

// Times of upward zero crossings of theta, linearly interpolated between steps.
std::vector<double> upward_crossings(const Rocking& s) {
  std::vector<double> t;
  for (std::size_t n = 1; n < s.theta.size(); ++n) {
    if (s.theta[n - 1] < 0.0 && s.theta[n] >= 0.0) {
      t.push_back(s.dt * (static_cast<double>(n) + s.theta[n - 1] / (s.theta[n - 1] - s.theta[n])));
    }
  }
  return t;
}

TEST(RollingEpsd, UndampedRockingPeriod) {
  const Rocking s = rock(0.0, 1000, 12);
  const std::vector<double> t = upward_crossings(s);
  ASSERT_GE(t.size(), 10U);
  const double period = (t.back() - t.front()) / static_cast<double>(t.size() - 1);
  // Symplectic Euler shortens the period by (omega_0 dt)^2 / 24 = 1.6e-6 at 1000 steps a period.
  EXPECT_NEAR(period / s.period, 1.0, 1e-5) << period << " vs " << s.period;
  // No damper: the amplitude stays (the map conserves a shadow energy); 1e-4 covers the maxima
  // being sampled at steps, (omega_0 dt)^2 / 8 = 5e-6, yet eta_r = 1e-5 would already fail it.
  double early = 0.0;
  double late = 0.0;
  for (std::size_t n = 0; n < 1000; ++n) early = std::max(early, s.theta[n]);
  for (std::size_t n = s.theta.size() - 1000; n < s.theta.size(); ++n) {
    late = std::max(late, s.theta[n]);
  }
  EXPECT_NEAR(late / early, 1.0, 1e-4);
}

TEST(RollingEpsd, DampedRockingLogDecrement) {
  const double eta = 0.3;
  const Rocking s = rock(eta, 4000, 4);
  // Successive maxima of theta (sampled at steps: 1e-6 relative at 4000 steps a period).
  std::vector<double> peak;
  std::vector<double> when;
  for (std::size_t n = 1; n + 1 < s.theta.size(); ++n) {
    if (s.theta[n] > s.theta[n - 1] && s.theta[n] >= s.theta[n + 1]) {
      peak.push_back(s.theta[n]);
      when.push_back(s.dt * static_cast<double>(n));
    }
  }
  ASSERT_GE(peak.size(), 3U);
  const double periods = static_cast<double>(peak.size() - 1);
  const double decrement = std::log(peak.front() / peak.back()) / periods;
  const double expected = 2.0 * std::numbers::pi * eta / std::sqrt(1.0 - eta * eta);
  // The damper takes the spin of the step start: a first-order error eta omega_0 dt = 4.7e-4.
  EXPECT_NEAR(decrement / expected, 1.0, 1e-3) << decrement << " vs " << expected;
  // Maxima are one damped period T_0 / sqrt(1 - eta^2) apart, to the step (dt / T_0 = 2.5e-4).
  const double damped_period = (when.back() - when.front()) / periods;
  EXPECT_NEAR(damped_period * std::sqrt(1.0 - eta * eta) / s.period, 1.0, 1e-3);
}

}  // namespace
}  // namespace bondem
