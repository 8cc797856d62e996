// Thermal coupling through the full stepper: a conducting pair against the closed-form
// relaxation, the heat-step stability stop, heat conservation in a colliding bed and the heat a
// held wall conducts into it, convective and radiative cooling against their solutions, the
// laser's energy balance, the temperature bonding criterion and its persistent bonds, identical
// bytes at 1 and 2 threads, and checkpoint restarts of the laser sintering case. Expected values
// are computed by hand, not with the solver's own helpers, so that a wrong helper cannot hide.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "io/case_file.hpp"
#include "io/run.hpp"
#include "run_helpers.hpp"
#include "scene_builders.hpp"
#include "solver/engine/laser.hpp"
#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"
#include "solver/experiments/calculator.hpp"

namespace bondem {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();

/// @p value in @p digits significant digits, for the measured numbers a test records.
std::string sci(double value, int digits = 3) {
  std::ostringstream text;
  text.precision(digits);
  text << value;
  return text.str();
}

/// One material (E = 5 MPa, nu = 0.3, rho = 2500) with the given specific heat and conductivity,
/// no bonding, temperatures on without convection or radiation.
Case thermal_case(double specific_heat, double conductivity) {
  Case c = testing::soft_case(0.3);
  c.materials[0].specific_heat = specific_heat;
  c.materials[0].thermal_conductivity = conductivity;
  c.thermal = ThermalModel{};
  c.thermal->convection_coefficient = 0.0;
  c.thermal->radiation = false;
  return c;
}

ParticleSpec particle(double radius, const Eigen::Vector3d& position, double temperature) {
  ParticleSpec p;
  p.radius = radius;
  p.position = position;
  p.temperature = temperature;
  return p;
}

/// m c_p of a sphere [J/K], by hand (independent of the solver's own helpers).
double ball_capacity(double radius, double density, double specific_heat) {
  return 4.0 / 3.0 * std::numbers::pi * radius * radius * radius * density * specific_heat;
}

/// Sum of C_i T_i [J], in index order.
double heat_content(const Particles& p) {
  double sum = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) sum += p.temperature[i] / p.inv_heat_capacity[i];
  return sum;
}

/// Centre distance of particles 0 and 1 subtracted from their radii, as the kernel forms it.
double pair_overlap(const Particles& p) {
  const double dx = p.x[1] - p.x[0];
  const double dy = p.y[1] - p.y[0];
  const double dz = p.z[1] - p.z[0];
  return p.radius[0] + p.radius[1] - std::sqrt(dx * dx + dy * dy + dz * dz);
}

// ---------------------------------------------------------------------------------------------
// A conducting pair

/// Two particles of radii 1 and 0.5 mm held at a fixed overlap by a bond whose equilibrium is
/// that overlap (alpha = 1), gravity off, at rest; conductivity @p k, c_p = 25 J/(kg K).
struct HeldPair {
  Case description;
  double overlap = 0.0;  ///< the initial overlap, as the kernel computes it [m]
  double conductance = 0.0;
  double capacity_1 = 0.0, capacity_2 = 0.0;
};

HeldPair held_pair(double k) {
  HeldPair pair;
  const double r1 = 1e-3;
  const double r2 = 0.5e-3;
  pair.description = thermal_case(25.0, k);
  Case& c = pair.description;
  c.particles.push_back(particle(r1, Eigen::Vector3d::Zero(), 1000.0));
  c.particles.push_back(particle(r2, Eigen::Vector3d(r1 + r2 - 1e-5, 0.0, 0.0), 300.0));
  pair.overlap = (r1 + r2) - c.particles[1].position.x();
  c.contact.bond.criterion = BondCriterion::kAlways;
  c.contact.bond.alpha = 1.0;
  c.contact.bond.input = AdhesionInput::kEquilibriumOverlap;
  c.contact.bond.equilibrium_overlap = pair.overlap;
  c.contact.bond.damping_ratio = 0.5;
  const double r_star = effective_radius(r1, r2);
  pair.conductance = 2.0 * k * std::sqrt(r_star) * std::sqrt(pair.overlap);
  const double density = c.materials[0].density;
  pair.capacity_1 = ball_capacity(r1, density, c.materials[0].specific_heat);
  pair.capacity_2 = ball_capacity(r2, density, c.materials[0].specific_heat);
  return pair;
}

TEST(ThermalPair, RelaxesAtTheAnalyticRate) {
  const HeldPair pair = held_pair(120.0);
  const Case& c = pair.description;
  const double dt = c.time_step;
  ASSERT_LE(dt, case_time_step_limit(c)) << "the mechanical step limit must hold";
  const double tau = 1.0 / (pair.conductance * (1.0 / pair.capacity_1 + 1.0 / pair.capacity_2));
  ASSERT_GT(tau / dt, 1000.0);  // a few thousand steps: ~2100
  ASSERT_LT(tau / dt, 5000.0);
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  const Particles& p = scene.particles;
  ASSERT_EQ(stepper.contacts().bonds, 1u);
  const double delta_t0 = p.temperature[0] - p.temperature[1];
  const double content0 = heat_content(p);
  const int steps = 4000;  // about 1.9 tau
  double worst_overlap = 0.0;
  double worst_content = 0.0;
  for (int s = 0; s < steps; ++s) {
    stepper.step();
    worst_overlap = std::max(worst_overlap, std::abs(pair_overlap(p) - pair.overlap));
    worst_content = std::max(worst_content, std::abs(heat_content(p) / content0 - 1.0));
  }
  // The bond force vanishes at the overlap it starts from, up to the rounding of the positions
  // (ulp of 1.5e-3 m ~ 2e-19 m): the pair must not move beyond rounding. Any real force (say one
  // millionth of the Hertz load) would shift it by ~1e-6 of the overlap; 1e-9 of it (1e-14 m)
  // leaves rounding a wide margin.
  EXPECT_LT(worst_overlap, 1e-9 * pair.overlap);

  // Forward Euler with a constant conductance gives exactly Delta T_n = Delta T0 (1 - dt/tau)^n,
  // whose ratio to the exponential is exp(-n (x^2/2 + x^3/3 + ...)) ~ 1 - n x^2 / 2, x = dt/tau:
  // ~4.5e-4 here. Allow 1.5 times that first-order error; a conductance off by 0.1 % already
  // moves the ratio by ~2e-3.
  const double t = stepper.time();
  const double x = dt / tau;
  const double ratio = (p.temperature[0] - p.temperature[1]) / delta_t0;
  const double euler_error = steps * x * x / 2.0;
  const double relative = std::abs(ratio / std::exp(-t / tau) - 1.0);
  EXPECT_LT(relative, 1.5 * euler_error) << "ratio " << ratio << " vs " << std::exp(-t / tau);
  // And against the discrete solution itself only rounding remains: ~n ulps of the temperatures
  // (4000 x 1e-16 relative to a difference of ~100 K), so 1e-10 is loose.
  const double discrete = std::pow(1.0 - x, steps);
  EXPECT_NEAR(ratio, discrete, 1e-10) << "relative to exp: " << relative;

  // The same flux leaves one particle and enters the other: C1 T1 + C2 T2 changes only by the
  // rounding of the two temperature updates, at most ~2 ulp of C T per step, so the drift stays
  // below 4 eps per step (worst case, no cancellation) over the run.
  EXPECT_LT(worst_content, 4.0 * kEps * steps);
  RecordProperty("relative_error_vs_exp", sci(relative));
  RecordProperty("error_vs_discrete", sci(ratio - discrete));
  RecordProperty("content_drift", sci(worst_content));
  RecordProperty("overlap_drift", sci(worst_overlap / pair.overlap));
}

TEST(ThermalStability, UnstableHeatStepStops) {
  // At dt H / C = 0.9 (the small particle's C) forward Euler is still a convex combination and
  // the run goes on; at 2 the step must stop with a message naming the heat step. The ratio the
  // stepper reports is the same product of three numbers, so it agrees to a few ulps (1e-12).
  const HeldPair probe = held_pair(1.0);
  const double ratio_per_k =
      probe.description.time_step * probe.conductance / probe.capacity_2;  // linear in k
  {
    const HeldPair pair = held_pair(0.9 / ratio_per_k);
    Scene scene = build_scene(pair.description);
    Stepper stepper(scene);
    EXPECT_NEAR(stepper.contacts().thermal_step_ratio, 0.9, 1e-12);
    EXPECT_NO_THROW(for (int s = 0; s < 20; ++s) stepper.step());
    // Still bounded by the initial temperatures: the discrete maximum principle.
    for (const double t : scene.particles.temperature) {
      EXPECT_GE(t, 300.0);
      EXPECT_LE(t, 1000.0);
    }
  }
  const HeldPair pair = held_pair(2.0 / ratio_per_k);
  Scene scene = build_scene(pair.description);
  Stepper stepper(scene);
  EXPECT_NEAR(stepper.contacts().thermal_step_ratio, 2.0, 2e-12);
  try {
    stepper.step();
    FAIL() << "an unstable heat step must stop the run";
  } catch (const BlowUpError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("heat step"), std::string::npos) << message;
    EXPECT_NE(message.find("time.step"), std::string::npos) << message;
  }
}

// ---------------------------------------------------------------------------------------------
// Conservation in a colliding bed

/// A frictional, damped gas of 400 particles (r 0.3-0.5 mm, solid fraction ~0.23) with random
/// velocities up to 2 m/s and random temperatures in [300, 1300] K, in a box periodic along
/// @p periodic_z or closed by a floor and a ceiling.
Case colliding_bed(bool periodic_z) {
  // k / c_p so large that a collision lasting ~30 steps exchanges a good part of the pair's
  // temperature difference while dt sum(H) / C stays well below 1.
  Case c = thermal_case(10.0, 4000.0);
  c.contact.friction = 0.5;
  c.contact.rolling_friction = 0.05;
  c.time_step = 5e-7;
  testing::add_random_gas(c, 400, 0.3e-3, 0.5e-3, 0.008, 2.0, 17);
  c.domain->periodic = {true, true, periodic_z};
  Rng rng(23);
  for (ParticleSpec& p : c.particles.expanded()) p.temperature = 300.0 + 1000.0 * uniform01(rng);
  return c;
}

/// Contacting pairs (by ids, smaller first) of the last force evaluation.
std::set<std::pair<std::int64_t, std::int64_t>> contact_pairs(const Scene& scene,
                                                              const Stepper& stepper) {
  std::set<std::pair<std::int64_t, std::int64_t>> pairs;
  const Particles& p = scene.particles;
  const NeighborList& list = stepper.neighbors();
  list.for_each_pair([&](std::size_t i, std::size_t j, std::uint32_t k) {
    if (!(stepper.pair_forces().conductance[k] > 0.0)) return;
    const std::int64_t a = p.id[i];
    const std::int64_t b = p.id[j];
    pairs.emplace(std::min(a, b), std::max(a, b));
  });
  return pairs;
}

double temperature_spread(const Particles& p) {
  double mean = 0.0;
  for (const double t : p.temperature) mean += t;
  mean /= static_cast<double>(p.size());
  double variance = 0.0;
  for (const double t : p.temperature) variance += (t - mean) * (t - mean);
  return std::sqrt(variance / static_cast<double>(p.size()));
}

TEST(ThermalConservation, ClosedBedKeepsItsHeat) {
  const Case c = colliding_bed(true);
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  const Particles& p = scene.particles;
  const double content0 = heat_content(p);
  const double spread0 = temperature_spread(p);
  const auto contacts0 = contact_pairs(scene, stepper);
  std::set<std::pair<std::int64_t, std::int64_t>> seen = contacts0;
  const int steps = 600;
  double worst = 0.0;
  double worst_ratio = 0.0;
  for (int s = 0; s < steps; ++s) {
    stepper.step();
    worst = std::max(worst, std::abs(heat_content(p) / content0 - 1.0));
    worst_ratio = std::max(worst_ratio, stepper.contacts().thermal_step_ratio);
    const auto now = contact_pairs(scene, stepper);
    seen.insert(now.begin(), now.end());
  }
  // The test means something only if contacts came and went and heat really flowed.
  EXPECT_GT(seen.size(), 3 * contacts0.size() + 100) << "contacts must change";
  EXPECT_LT(temperature_spread(p), 0.9 * spread0) << "heat must flow";
  EXPECT_GT(stepper.neighbors().build_count(), 2);
  // Every contact's flux enters one particle and leaves the other, so only rounding changes
  // sum C T: each step rounds each T update (<= 1 ulp of T ~ 1.1e-16 relative), the per-particle
  // flux sums and C (1/C) ~ 1 (a few ulps of the small exchanged heat) and the content sum itself
  // (400 terms, ~1e-14). Worst case without cancellation: 600 steps x 2 eps ~ 3e-13; 1e-12 keeps a
  // margin. One contact's flux over one step is ~1e-5 of the content: losing even a millionth of
  // the fluxes on one side shows up (~1e-8).
  EXPECT_LT(worst, 1e-12);
  EXPECT_LT(worst_ratio, 1.0);
  RecordProperty("content_drift", sci(worst));
  RecordProperty("thermal_step_ratio", sci(worst_ratio));
}

TEST(ThermalConservation, HeldWallSuppliesWhatItConducts) {
  // The colliding bed closed by a floor held at 1500 K (of a steel-like conductivity, so the
  // harmonic mean matters) and an adiabatic ceiling: the heat the particles gain equals the sum
  // over steps of dt 2 k_eff sqrt(r delta) (T_wall - T_i), evaluated here from the positions
  // at which the stepper took its forces (those after the drift) and the temperatures at the
  // step's start.
  Case c = colliding_bed(false);
  c.reorder_interval = 0;  // indices stay put: per-index bookkeeping
  c.materials.push_back({"steel", 7800.0, 5.0e6, 0.3, 500.0, 16.0, 0.0});
  const bool open[6] = {true, true, true, true, false, false};
  c.boundaries = box_container(Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(0.008), 1, open);
  c.boundaries[0].temperature = 1500.0;  // floor
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  const Particles& p = scene.particles;
  const double k_eff = 2.0 * 4000.0 * 16.0 / (4000.0 + 16.0);  // harmonic mean, W/(m K)
  const double dt = c.time_step;
  const double content0 = heat_content(p);
  double supplied = 0.0;
  int touching_steps = 0;
  for (int s = 0; s < 600; ++s) {
    const StaggeredVector<double> start = p.temperature;
    stepper.step();
    for (std::size_t i = 0; i < p.size(); ++i) {
      const double overlap = p.radius[i] - p.z[i];
      if (!(overlap > 0.0)) continue;
      ++touching_steps;
      supplied += dt * 2.0 * k_eff * std::sqrt(p.radius[i] * overlap) * (1500.0 - start[i]);
    }
  }
  const double bound = 600 * 2.0 * kEps * content0;  // as in ClosedBedKeepsItsHeat: 2 eps a step
  const double gained = heat_content(p) - content0;
  ASSERT_GT(touching_steps, 100) << "particles must touch the floor";
  ASSERT_GT(supplied, 1e3 * bound) << "the floor must supply measurable heat";
  // Rounding of the content (the bound above) plus that of the sum over contacts (~1e-13 of it).
  EXPECT_NEAR(gained, supplied, bound + 1e-12 * std::abs(supplied))
      << "relative error " << gained / supplied - 1.0;
  RecordProperty("relative_error", sci(gained / supplied - 1.0));
  RecordProperty("supplied_over_content", sci(supplied / content0));
}

// ---------------------------------------------------------------------------------------------
// Exchange with the surroundings

/// One isolated 1 mm particle at @p t0 [K] (c_p = 25) with ambient 300 K; dt = 10 us (nothing
/// touches it, so only the heat step matters).
Case lone_particle(double t0) {
  Case c = thermal_case(25.0, 0.0);
  c.time_step = 1e-5;
  c.thermal->ambient_temperature = 300.0;
  c.particles.push_back(particle(1e-3, Eigen::Vector3d::Zero(), t0));
  return c;
}

TEST(ThermalSurroundings, ConvectionCoolsAtTheEulerRate) {
  // C dT/dt = h A (T_amb - T): forward Euler gives exactly (T_n - T_amb) = (T0 - T_amb)(1 - x)^n,
  // x = dt h A / C; against the exponential the first-order error n x^2 / 2 (~1e-3 here) is
  // allowed 1.5 times, against the discrete solution only rounding (~n ulps of 1e3 K, 1e-10).
  Case c = lone_particle(1500.0);
  c.thermal->convection_coefficient = 2000.0;
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  const Particles& p = scene.particles;
  const double capacity = ball_capacity(1e-3, 2500.0, 25.0);
  const double x = c.time_step * 2000.0 * (4.0 * std::numbers::pi * 1e-6) / capacity;
  const int steps = 2000;
  for (int s = 0; s < steps; ++s) stepper.step();
  const double ratio = (p.temperature[0] - 300.0) / 1200.0;
  ASSERT_LT(ratio, 0.5);  // it did cool: ~0.15 of the initial excess is left
  EXPECT_NEAR(ratio, std::pow(1.0 - x, steps), 1e-10);
  const double relative = std::abs(ratio / std::exp(-steps * x) - 1.0);
  EXPECT_LT(relative, 1.5 * steps * x * x / 2.0);
  EXPECT_EQ(p.peak_temperature[0], 1500.0);  // cooling never raises the peak
  RecordProperty("relative_error_vs_exp", sci(relative));
}

/// Time for a body obeying dT/dt = -k (T^4 - a^4) to go from @p t0 to @p t (t0 > t > a):
/// F(t0) - F(t) over k, with F(T) = [ln((T - a)/(T + a)) - 2 atan(T / a)] / (4 a^3), whose
/// derivative is 1 / (T^4 - a^4).
double radiative_cooling_time(double t0, double t, double a, double k) {
  const auto f = [a](double temperature) {
    return (std::log((temperature - a) / (temperature + a)) - 2.0 * std::atan(temperature / a)) /
           (4.0 * a * a * a);
  };
  return (f(t0) - f(t)) / k;
}

TEST(ThermalSurroundings, RadiationCoolsAsTheClosedForm) {
  // eps sigma A (T_amb^4 - T^4) alone. The exact T(t) comes from inverting
  // radiative_cooling_time by bisection. Forward Euler on a contracting ODE has a global error
  // of at most (dt / 2) t max|T''|, T'' = f'(T) f(T) = 4 k^2 T^3 (T^4 - a^4), largest at T0.
  Case c = lone_particle(1500.0);
  c.materials[0].emissivity = 0.8;
  c.materials[0].specific_heat = 10.0;  // cools well below 1000 K in 5000 steps
  c.thermal->radiation = true;
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  const Particles& p = scene.particles;
  const double a = 300.0;
  const double k =
      0.8 * 5.670374419e-8 * (4.0 * std::numbers::pi * 1e-6) / ball_capacity(1e-3, 2500.0, 10.0);
  const int steps = 5000;
  for (int s = 0; s < steps; ++s) stepper.step();
  const double t = stepper.time();
  double lo = a + 1e-9;
  double hi = 1500.0;
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    (radiative_cooling_time(1500.0, mid, a, k) > t ? lo : hi) = mid;
  }
  const double exact = 0.5 * (lo + hi);
  const double t0 = 1500.0;
  const double bound =
      0.5 * c.time_step * t * 4.0 * k * k * t0 * t0 * t0 * (t0 * t0 * t0 * t0 - a * a * a * a);
  ASSERT_LT(exact, 1000.0);  // it did cool, by more than a third of the excess
  EXPECT_NEAR(p.temperature[0], exact, bound);
  // The error is one-sided: Euler takes the rate at the start of each step, the fastest within it
  // (the loss grows with T), and its map T -> T + dt f(T) is increasing, so it stays below the
  // exact curve; anything above it by more than rounding is wrong.
  EXPECT_LE(p.temperature[0], exact + 1e-9);
  RecordProperty("error_K", sci(p.temperature[0] - exact));
  RecordProperty("bound_K", sci(bound));
}

// ---------------------------------------------------------------------------------------------
// The laser

/// Ti-6Al-4V-like powder (rho 4430, E 10 MPa, c_p 560, k 7) and a steel-like substrate material.
Case powder_case() {
  Case c;
  c.source = "test";
  c.materials.push_back({"ti64", 4430.0, 1.0e7, 0.34, 560.0, 7.0, 0.3});
  c.materials.push_back({"steel", 7800.0, 1.0e7, 0.3, 500.0, 16.0, 0.0});
  c.contact.damping_ratio = 0.3;
  c.contact.bond.criterion = BondCriterion::kNever;
  c.contact.bond.equilibrium_overlap = 3e-7;
  c.time_step = 6.5e-8;
  c.end_time = 1.0;
  c.thermal = ThermalModel{};
  return c;
}

TEST(ThermalLaser, AbsorbedEnergyIsPowerTimesAbsorptivityTimesExposure) {
  // A monolayer of 24 x 14 particles (r = 25 um) at 2.1 r spacing, gravity off, at rest: no
  // contact ever forms, so the particles' heat can only come from the beam. The beam window
  // (half-width 3 w) stays on the bed along the whole path.
  Case c = powder_case();
  c.time_step = 2e-6;  // no contacts and no motion: only the beam's sampling matters
  c.thermal->convection_coefficient = 0.0;
  c.thermal->radiation = false;
  const double r = 25e-6;
  const double spacing = 2.1 * r;
  const double t0 = 300.0;
  for (int j = 0; j < 14; ++j) {
    for (int i = 0; i < 24; ++i) {
      c.particles.push_back(
          particle(r, Eigen::Vector3d((i + 0.5) * spacing, (j + 0.5) * spacing, r), t0));
    }
  }
  const double y_path = 7.5 * spacing;  // on row 7
  // The beam is on from 6.2 dt for 420.4 dt: sampled at mid-step, (s + 1/2) dt, that is steps 6
  // to 426, 421 of them; sampling at the start or the end of each step would give 420.
  const double dt = c.time_step;
  const double speed = 0.5;
  const double x_start = 8.0 * spacing;
  const double x_end = x_start + 420.4 * dt * speed;  // 0.42 mm, 8 spacings
  Laser laser{9.0, 80e-6, 0.35, 6.2 * dt, {}};
  laser.path.push_back({Eigen::Vector2d(x_start, y_path), Eigen::Vector2d(x_end, y_path), speed});
  c.laser = laser;
  const double exposure = laser_end_time(laser) - laser.start_time;
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  const Particles& p = scene.particles;
  const double content0 = heat_content(p);
  const int steps = 440;  // past the end of the path
  int sampled_steps = 0;
  for (int s = 0; s < steps; ++s) {
    const double mid = (s + 0.5) * dt;
    sampled_steps += mid >= laser.start_time && mid < laser_end_time(laser) ? 1 : 0;
    stepper.step();
  }
  ASSERT_EQ(sampled_steps, 421);
  ASSERT_EQ(stepper.contacts().contacts, 0u);

  // The energy delivered is that of the exposure rounded to whole steps: within one step of
  // power (alpha P dt) of the exact product. Beyond that only the window's cut (4e-9 of P) and
  // rounding remain: 1e-6 relative is loose.
  const double absorbed = laser.absorptivity * laser.power;
  const double total = stepper.laser_energy() + stepper.laser_missed();
  const double expected = absorbed * exposure;
  EXPECT_NEAR(total, expected, absorbed * dt + 1e-6 * expected);
  // Sharper: each of the 421 sampled steps deposits alpha P erf(3 sqrt2)^2 (the window's share)
  // up to the rounding of its column sum (~1e4 columns, < 1e-12) and of the running total
  // (440 additions): 1e-10 relative. One step more or less would be 2.4e-3 off.
  const double window = std::erf(3.0 * std::numbers::sqrt2) * std::erf(3.0 * std::numbers::sqrt2);
  const double sampled = sampled_steps * dt * absorbed * window;
  EXPECT_NEAR(total, sampled, 1e-10 * sampled) << "relative " << total / sampled - 1.0;
  // The discs cover pi / 2.1^2 = 71 % of the plane: most of the beam lands on particles, the
  // rest falls through the gaps.
  EXPECT_GT(stepper.laser_energy(), 0.5 * expected);
  EXPECT_GT(stepper.laser_missed(), 0.05 * expected);

  // Adiabatic otherwise: the particles hold exactly what the stepper says they absorbed, up to
  // the rounding of each temperature update (<= 1 ulp of C T per particle and step, bounded by
  // steps x eps x the final content) and of the content sums.
  const double content = heat_content(p);
  const double gained = content - content0;
  const double rounding = (steps + static_cast<double>(p.size())) * kEps * content;
  EXPECT_NEAR(gained, stepper.laser_energy(), rounding)
      << "relative " << gained / stepper.laser_energy() - 1.0;

  // The hottest particle lies on the path: on row 7 and between its ends.
  const auto hottest = static_cast<std::size_t>(
      std::max_element(p.temperature.begin(), p.temperature.end()) - p.temperature.begin());
  EXPECT_LT(std::abs(p.y[hottest] - y_path), 0.5 * spacing);
  EXPECT_GE(p.x[hottest], x_start - r);
  EXPECT_LE(p.x[hottest], x_end + r);
  EXPECT_GT(p.temperature[hottest], t0 + 100.0);
  RecordProperty("relative_error_vs_exposure", sci(total / expected - 1.0));
  RecordProperty("relative_error_vs_sampled", sci(total / sampled - 1.0));
  RecordProperty("content_vs_laser_energy", sci(gained / stepper.laser_energy() - 1.0));
  RecordProperty("hottest_temperature", sci(p.temperature[hottest]));
}

// ---------------------------------------------------------------------------------------------
// Bonding by temperature

/// Two 1 mm spheres stacked on a floor under gravity, placed at their Hertz rest overlaps (so
/// they start in equilibrium and stay in contact without a bond), bottom at @p t_bottom, top at
/// @p t_top; criterion temperature at 800 K with alpha = 0 (delta_crit = 0: a touching pair
/// qualifies). c_p = 10 and k = 720 put the exchange time constant at ~1500 steps.
struct Stack {
  Case description;
  double overlap = 0.0;  ///< pair overlap at rest [m]
  double tau = 0.0;      ///< 1 / (H (1/C1 + 1/C2)) at that overlap [s]
};

Stack stack_on_floor(double t_bottom, double t_top) {
  Stack stack;
  Case& c = stack.description;
  c = thermal_case(10.0, 720.0);
  const double r = 1e-3;
  const double g = 9.81;
  c.gravity = Eigen::Vector3d(0.0, 0.0, -g);
  c.boundaries.push_back(
      plane_boundary(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), 0, "floor"));
  c.contact.bond.criterion = BondCriterion::kTemperature;
  c.contact.bond.temperature = 800.0;
  c.contact.bond.alpha = 0.0;
  c.normal_law = BondLawSpec{};
  c.contact.bond.equilibrium_overlap = 1e-5;
  c.contact.bond.damping_ratio = 0.5;
  const Material& m = c.materials[0];
  const double e_star =
      effective_modulus(m.youngs_modulus, m.poisson_ratio, m.youngs_modulus, m.poisson_ratio);
  const double weight = sphere_mass(r, m.density) * g;
  // Hertz K delta^(3/2) carries the top's weight between the two, both weights on the floor.
  const double pair_rest = std::pow(weight / hertz_stiffness(e_star, 0.5 * r), 2.0 / 3.0);
  const double floor_rest = std::pow(2.0 * weight / hertz_stiffness(e_star, r), 2.0 / 3.0);
  const double z_bottom = r - floor_rest;
  const double z_top = z_bottom + 2.0 * r - pair_rest;
  c.particles.push_back(particle(r, Eigen::Vector3d(0.0, 0.0, z_bottom), t_bottom));
  c.particles.push_back(particle(r, Eigen::Vector3d(0.0, 0.0, z_top), t_top));
  stack.overlap = 2.0 * r - (z_top - z_bottom);
  const double capacity = ball_capacity(r, m.density, m.specific_heat);
  const double h = 2.0 * m.thermal_conductivity * std::sqrt(0.5 * r) * std::sqrt(stack.overlap);
  stack.tau = capacity / (2.0 * h);
  return stack;
}

/// Index of the particle with id @p id (the stepper may reorder).
std::size_t index_of(const Particles& p, std::int64_t id) {
  return static_cast<std::size_t>(std::find(p.id.begin(), p.id.end(), id) - p.id.begin());
}

/// Bond flags set in the stepper's pair slots.
int bond_flags(const Stepper& stepper) {
  const StaggeredVector<std::uint8_t>& bonded = stepper.pair_forces().bonded;
  return static_cast<int>(std::count(bonded.begin(), bonded.end(), std::uint8_t{1}));
}

TEST(ThermalBonding, PairBondsOnlyAfterCriterionHolds) {
  // Equal capacities at 1500 and 300 K relax toward 900 K; the cold one reaches T_bond = 800 K
  // when Delta T = 200 K = Delta T0 / 6, at t* = tau ln 6.
  const Stack stack = stack_on_floor(1500.0, 300.0);
  const Case& c = stack.description;
  const double dt = c.time_step;
  ASSERT_LE(dt, case_time_step_limit(c));
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  const Particles& p = scene.particles;
  ASSERT_EQ(stepper.contacts().contacts, 1u);
  ASSERT_EQ(bond_flags(stepper), 0);
  const double crossing = stack.tau * std::log(6.0) / dt;  // in steps, ~2700
  ASSERT_GT(crossing, 1000.0);
  std::vector<double> cold{p.temperature[index_of(p, 1)]};  // after each step
  int first_bonded = -1;
  const int steps = static_cast<int>(crossing) + 1000;
  for (int s = 1; s <= steps; ++s) {
    stepper.step();
    cold.push_back(p.temperature[index_of(p, 1)]);
    ASSERT_EQ(stepper.contacts().contacts, 1u) << "step " << s;
    const int bonded = bond_flags(stepper);
    if (first_bonded < 0 && bonded == 1) first_bonded = s;
    ASSERT_EQ(bonded, first_bonded < 0 ? 0 : 1) << "step " << s;
  }
  ASSERT_GT(first_bonded, 1);
  // The criterion reads the temperatures at the start of a step: the bond appears in the first
  // step that starts with the cold particle at or above 800 K, not one step earlier or later.
  EXPECT_GE(cold[static_cast<std::size_t>(first_bonded - 1)], 800.0);
  EXPECT_LT(cold[static_cast<std::size_t>(first_bonded - 2)], 800.0);
  // Forward Euler reaches Delta T0 / 6 after ln 6 / -ln(1 - x) = t*/dt - ln6/2 + O(x) steps
  // (x = dt / tau), ~0.9 step early, and the criterion is read one step later: the bond appears
  // at t*/dt + [0.1, 1.1) steps. 1.5 steps either way covers that with margin; a conductance
  // off by 0.1 % shifts the crossing by ~2.7 steps.
  EXPECT_NEAR(first_bonded, crossing, 1.5);
  EXPECT_EQ(stepper.bonds_formed(), 1);
  EXPECT_EQ(stepper.bonds_broken(), 0);
  RecordProperty("first_bonded_step", first_bonded);
  RecordProperty("analytic_crossing_step", sci(crossing, 7));
}

TEST(ThermalBonding, SolidifiedNeckSurvivesCooling) {
  // Both particles start at 1000 K, above T_bond = 800 K, so the pair bonds in the first
  // evaluation; strong convection (h = 8000 W/(m^2 K), time constant rho r c_p / (3 h) ~ 1 ms)
  // then cools both to ambient 300 K. The bond must persist: only the overlap returning to
  // delta_crit (0 here) may break it.
  Stack stack = stack_on_floor(1000.0, 1000.0);
  Case& c = stack.description;
  c.thermal->convection_coefficient = 8000.0;
  c.thermal->ambient_temperature = 300.0;
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  const Particles& p = scene.particles;
  ASSERT_EQ(bond_flags(stepper), 1);
  ASSERT_EQ(stepper.bonds_formed(), 1);
  int s = 0;
  for (; s < 20000 && std::max(p.temperature[0], p.temperature[1]) > 600.0; ++s) {
    stepper.step();
    ASSERT_EQ(stepper.contacts().contacts, 1u) << "step " << s;
    ASSERT_EQ(bond_flags(stepper), 1) << "step " << s;
  }
  for (int extra = 0; extra < 500; ++extra) stepper.step();  // well below T_bond
  EXPECT_EQ(bond_flags(stepper), 1);
  EXPECT_LT(std::max(p.temperature[0], p.temperature[1]), 600.0);
  EXPECT_EQ(stepper.bonds_formed(), 1);
  EXPECT_EQ(stepper.bonds_broken(), 0);
  // The bond, not gravity, now sets the overlap: pulled toward delta_eq = 10 um, far beyond the
  // 1.2 um rest overlap of the unbonded stack.
  EXPECT_GT(pair_overlap(p), 5.0 * stack.overlap);
  RecordProperty("cooling_steps", s);
}

// ---------------------------------------------------------------------------------------------
// Thread-count independence

/// What must not depend on the thread count.
struct ThermalSnapshot {
  StaggeredVector<std::int64_t> id;
  StaggeredVector<double> x, y, z, vx, vy, vz, temperature, peak_temperature;
  StaggeredVector<std::uint8_t> bonded;
  std::int64_t bonds_formed = 0, bonds_broken = 0, builds = 0;
  double laser_energy = 0.0, laser_missed = 0.0;
};

ThermalSnapshot run_with_threads(const Case& c, int threads, int steps) {
  const int saved = omp_get_max_threads();
  omp_set_num_threads(threads);
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  for (int s = 0; s < steps; ++s) stepper.step();
  omp_set_num_threads(saved);
  const Particles& p = scene.particles;
  return {p.id,
          p.x,
          p.y,
          p.z,
          p.vx,
          p.vy,
          p.vz,
          p.temperature,
          p.peak_temperature,
          stepper.pair_forces().bonded,
          stepper.bonds_formed(),
          stepper.bonds_broken(),
          stepper.neighbors().build_count(),
          stepper.laser_energy(),
          stepper.laser_missed()};
}

template <class T, class Allocator>
bool same_bytes(const std::vector<T, Allocator>& a, const std::vector<T, Allocator>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

TEST(ThermalDeterminism, SameBytesAtOneAndTwoThreads) {
  // 48 x 48 = 2304 particles (above kMinParallelParticles) on a substrate held at 353 K, slightly
  // compressed (spacing 0.999 d) and jiggled with random velocities, with convection, radiation,
  // a laser crossing the layer and criterion temperature (1100 K start, bonds at 1200 K). A small
  // skin forces rebuilds and reordering. Every result must be the same bits: no tolerance.
  Case c = powder_case();
  c.contact.friction = 0.5;
  c.contact.rolling_friction = 0.1;
  c.contact.bond.criterion = BondCriterion::kTemperature;
  c.contact.bond.temperature = 1200.0;
  c.contact.bond.alpha = 0.0;
  c.normal_law = BondLawSpec{};
  c.contact.bond.damping_ratio = 1.0;
  c.thermal->initial_temperature = 1100.0;
  c.thermal->ambient_temperature = 353.0;
  c.thermal->convection_coefficient = 10.0;
  c.thermal->radiation = true;
  c.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  c.boundaries.push_back(
      plane_boundary(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), 1, "substrate", 353.0));
  c.skin = 1e-6;
  c.reorder_interval = 2;
  const double r = 15e-6;
  const double spacing = 2.0 * r * 0.999;
  Rng rng(5);
  for (int j = 0; j < 48; ++j) {
    for (int i = 0; i < 48; ++i) {
      ParticleSpec s =
          particle(r, Eigen::Vector3d((i + 0.5) * spacing, (j + 0.5) * spacing, r), 1100.0);
      for (int a = 0; a < 3; ++a) s.velocity[a] = 0.05 * (2.0 * uniform01(rng) - 1.0);
      c.particles.push_back(s);
    }
  }
  Laser laser{100.0, 80e-6, 0.35, 0.0, {}};
  laser.path.push_back(
      {Eigen::Vector2d(0.2e-3, 24.0 * spacing), Eigen::Vector2d(1.2e-3, 24.0 * spacing), 20.0});
  c.laser = laser;
  ASSERT_LE(c.time_step, case_time_step_limit(c));
  ASSERT_GE(c.particles.size(), kMinParallelParticles);
  const int steps = 300;
  const ThermalSnapshot one = run_with_threads(c, 1, steps);
  const ThermalSnapshot two = run_with_threads(c, 2, steps);
  // The run must exercise what it claims to.
  EXPECT_GT(one.bonds_formed, 0);
  EXPECT_GT(one.laser_energy, 0.0);
  EXPECT_GT(one.builds, 2);
  EXPECT_TRUE(same_bytes(one.id, two.id));
  EXPECT_TRUE(same_bytes(one.x, two.x));
  EXPECT_TRUE(same_bytes(one.y, two.y));
  EXPECT_TRUE(same_bytes(one.z, two.z));
  EXPECT_TRUE(same_bytes(one.vx, two.vx));
  EXPECT_TRUE(same_bytes(one.vy, two.vy));
  EXPECT_TRUE(same_bytes(one.vz, two.vz));
  EXPECT_TRUE(same_bytes(one.temperature, two.temperature));
  EXPECT_TRUE(same_bytes(one.peak_temperature, two.peak_temperature));
  EXPECT_TRUE(same_bytes(one.bonded, two.bonded));
  EXPECT_EQ(one.bonds_formed, two.bonds_formed);
  EXPECT_EQ(one.bonds_broken, two.bonds_broken);
  // The bytes are what is compared: identical runs, not merely equal values.
  EXPECT_EQ(std::memcmp(&one.laser_energy, &two.laser_energy, sizeof(double)),  // NOLINT
            0);
  EXPECT_EQ(std::memcmp(&one.laser_missed, &two.laser_missed, sizeof(double)),  // NOLINT
            0);
  RecordProperty("bonds_formed", static_cast<int>(one.bonds_formed));
  RecordProperty("neighbor_builds", static_cast<int>(one.builds));
}

// ---------------------------------------------------------------------------------------------
// Restart

namespace fs = std::filesystem;

/// The CI sintering case shortened to 4000 steps: the laser starts at 50 us and crosses the strip
/// at 2 m/s with 20 W from 1150 K, so bonds form while it runs; a history row every 200 steps.
Case short_sintering(double end_time) {
  return load_case(BONDEM_CASES_DIR "/laser_sintering_ci.yaml",
                   {"time.end=" + std::to_string(end_time), "laser.start_time=0.00005",
                    "laser.path.0.speed=2", "laser.power=20", "thermal.initial_temperature=1150",
                    "output.history_interval=1.3e-5", "output.vtk_interval=1"});
}

TEST(ThermalRestart, ContinuingACheckpointGivesTheSameBytes) {
  // As Restart.ContinuingACheckpointGivesTheSameBytes: once whole to 260 us (4000 steps), once to
  // 208 us (3200 steps, a multiple of the history interval, with the beam on and bonds already
  // formed) and continued from its checkpoint. Temperatures, peak temperatures, bonds, laser
  // energy and history rows must be the same bytes.
  const fs::path whole = testing::fresh_directory("thermal_whole");
  const fs::path parts = testing::fresh_directory("thermal_parts");
  const RunResult full = testing::quiet_run(short_sintering(0.00026), whole);
  const RunResult first = testing::quiet_run(short_sintering(0.000208), parts);
  const RunResult second =
      testing::quiet_run(short_sintering(0.00026), parts, (parts / "checkpoint.bin").string());
  ASSERT_TRUE(full.thermal && first.thermal && second.thermal);
  EXPECT_GT(first.bonds_formed, 0) << "bonds must cross the checkpoint";
  EXPECT_GT(full.bonds_formed, first.bonds_formed) << "and more must form after it";
  EXPECT_GT(first.thermal->laser_energy, 0.0);
  EXPECT_GT(full.thermal->laser_energy, first.thermal->laser_energy);
  EXPECT_EQ(second.bonds_formed, full.bonds_formed);
  EXPECT_EQ(second.thermal->laser_energy, full.thermal->laser_energy);
  const std::string final_whole = testing::file_bytes(whole / "final_state.csv");
  EXPECT_NE(final_whole.find("temperature,peak_temperature"), std::string::npos);
  EXPECT_TRUE(final_whole == testing::file_bytes(parts / "final_state.csv"));
  EXPECT_TRUE(testing::file_bytes(whole / "history.csv") ==
              testing::file_bytes(parts / "history.csv"));
  RecordProperty("bonds_at_checkpoint", static_cast<int>(first.bonds_formed));
  RecordProperty("bonds_at_end", static_cast<int>(full.bonds_formed));
}

}  // namespace
}  // namespace bondem
