// The time-step guard: damper stability, tool speed, non-finite derived quantities.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "io/case_file.hpp"
#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"
#include "solver/experiments/calculator.hpp"
#include "solver/experiments/collision.hpp"

namespace bondem {
namespace {

/// Spectral radius of the one-step map of Stepper::step() for m x'' = -k x - c v with the damper
/// fed the half-step velocity: (x, v_half) -> (x', v_half'), omega dt = w, 2 xi omega dt = b.
double verlet_spectral_radius(double w, double damping_ratio) {
  const double b = 2.0 * damping_ratio * w;
  const double trace = 2.0 - w * w - b;
  const double determinant = 1.0 - b;
  const std::complex<double> root =
      std::sqrt(std::complex<double>(trace * trace - 4.0 * determinant));
  return std::max(std::abs(0.5 * (trace + root)), std::abs(0.5 * (trace - root)));
}

TEST(DamperBound, IsTheStabilityEdgeOfTheSteppersScheme) {
  for (const double xi : {0.0, 0.1, 0.5, 1.0, 10.0, 1000.0}) {
    const double edge = damped_stability_step(1.0, 1.0, xi);  // omega = 1: edge = omega dt
    // The edge itself has |lambda| = 1; 0.1 % either side is inside and outside the unit circle
    // (undamped, inside means on it: |lambda| = 1 to round-off).
    if (xi > 0.0) {
      EXPECT_LT(verlet_spectral_radius(0.999 * edge, xi), 1.0) << "xi " << xi;
    } else {
      EXPECT_LE(verlet_spectral_radius(0.999 * edge, xi), 1.0 + 1e-12);
    }
    EXPECT_GT(verlet_spectral_radius(1.001 * edge, xi), 1.0) << "xi " << xi;
  }
  // Undamped: the textbook 2 / omega.
  EXPECT_DOUBLE_EQ(damped_stability_step(4.0, 1.0, 0.0), 1.0);
  // The safety factor: the pair bound with omega and xi both doubled (a mode 4x as stiff).
  EXPECT_DOUBLE_EQ(damper_time_step(3.0, 2.0, 0.7), damped_stability_step(12.0, 2.0, 1.4));
  // No overflow for absurd ratios: a tiny positive step, never NaN or 0.
  const double absurd = damped_stability_step(1.0, 1.0, 1e300);
  EXPECT_GT(absurd, 0.0);
  EXPECT_LT(absurd, 1e-299);
}

/// One particle resting on a floor under gravity: about its static overlap a damped linear
/// oscillator of stiffness k = 2 E* sqrt(r delta_s) and mass m (a wall contact: r* = r, m* = m).
/// Returns the largest vertical speed over @p steps steps at @p step_factor times the exact
/// bound, relative to the initial push. (Above the bound the motion grows until the sign rule, a
/// contact never pulls, clips the damper; then it saturates: hence the peak, not the last speed.)
double floor_oscillation_growth(double damping_ratio, double step_factor, int steps) {
  Case c = parse_case(R"(
materials:
  m: {density: 2000, youngs_modulus: 1.0e9, poisson_ratio: 0.0}
contact: {damping_ratio: 0.0}
gravity: [0.0, 0.0, -1000.0]
walls:
  - {type: plane, point: [0.0, 0.0, 0.0], normal: [0.0, 0.0, 1.0], material: m, name: floor}
particles:
  - {material: m, radius: 0.001, position: [0.0, 0.0, 0.001], velocity: [0.0, 0.0, 0.0]}
time: {step: 1.0e-7, end: 1.0}
)",
                      "<floor>");
  c.contact.damping_ratio = damping_ratio;
  const double r = 1e-3;
  const double m = sphere_mass(r, 2000.0);
  const double e_star = c.pair_coefficients(0, 0).effective_modulus;
  // m g = (4/3) E* sqrt(r) delta_s^(3/2)
  const double static_overlap =
      std::pow(m * 1000.0 / (4.0 / 3.0 * e_star * std::sqrt(r)), 2.0 / 3.0);
  const double k = 2.0 * e_star * std::sqrt(r * static_overlap);
  const double omega = std::sqrt(k / m);
  // A push far too small to reach the sign rule (damping force << the weight) or to change k.
  const double push = 1e-7 * static_overlap * omega;
  c.particles.edit(0).position.z() = r - static_overlap;
  c.particles.edit(0).velocity.z() = push;
  c.time_step = step_factor * damped_stability_step(k, m, damping_ratio);
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  double peak_speed = 0.0;
  for (int s = 0; s < steps; ++s) {
    stepper.step();
    peak_speed = std::max(peak_speed, std::abs(scene.particles.vz[0]));
  }
  return peak_speed / push;
}

TEST(DamperBound, ContactOscillationDecaysJustBelowAndGrowsJustAbove) {
  // 2 % either side of the exact bound: the nonlinearity of Hertz over the push (k varies by
  // 1e-7 relative) is far smaller. 2 % above, the alternating mode grows by 4 % (xi = 50) to
  // 14 % (xi = 0.3) per step, so 3 000 steps multiply it by far more than 10 before the sign
  // rule caps it (near 1e6 / xi times the push); 2 % below, the motion never exceeds the
  // push: no energy gain.
  for (const double xi : {0.3, 2.0, 50.0}) {
    EXPECT_LE(floor_oscillation_growth(xi, 0.98, 3000), 1.0) << "xi " << xi;
    EXPECT_GT(floor_oscillation_growth(xi, 1.02, 3000), 10.0) << "xi " << xi;
  }
}

Case paper_case() {
  return load_case(BONDEM_CASES_DIR "/paper_5_1.yaml");
}

TEST(DamperBound, TwoParticleImpactGainsNoEnergyBelowTheBound) {
  // A Hertz impact (no bond) with xi_con = 1 and a few steps per contact: the stiffness reaches
  // its largest value, that of the undamped maximum overlap, only near the turning point, so the
  // exact bound at that stiffness separates a lossy rebound from one that gains energy.
  Case c = paper_case();
  c.contact.bond.criterion = BondCriterion::kNever;
  c.contact.damping_ratio = 1.0;
  const double v = 1.3;
  const PairReport r = compute_pair_report(c, 0, 1e-3, 0, 1e-3, v);
  const double edge = damped_stability_step(r.contact_stiffness, r.effective_mass, 1.0);
  c.time_step = 0.9 * edge;
  EXPECT_LT(collide(c, v).restitution, 1.0);  // kinetic energy x e^2: lost
  c.time_step = 1.2 * edge;
  EXPECT_GT(collide(c, v).restitution, 1.0);  // gained: the bound is real
  // The case limit (packing safety factor) lies well inside the edge.
  c.time_step = 5e-7;
  EXPECT_LT(case_time_step_limit(c), 0.5 * edge);
}

TEST(CaseLimit, LargeDampingRatiosAreRefusedNamingTheDamper) {
  Case c = paper_case();
  c.contact.damping_ratio = 1000.0;
  const TimeStepLimit contact = case_time_step_bound(c);
  EXPECT_LT(contact.step, c.time_step);
  EXPECT_NE(contact.cause.find("contact damper (contact.damping_ratio = 1000)"), std::string::npos)
      << contact.cause;
  c.contact.damping_ratio = 0.0;
  c.contact.bond.damping_ratio = 1000.0;
  const TimeStepLimit bond = case_time_step_bound(c);
  EXPECT_LT(bond.step, c.time_step);
  EXPECT_NE(bond.cause.find("bond damper (bond.damping_ratio = 1000)"), std::string::npos)
      << bond.cause;
}

TEST(CaseLimit, ShippedCasesAndPaperFiguresPassTheirLimit) {
  // A case that starts from another run's state (initial_state) gets, instead of that run's
  // output, a state of the smallest and the largest powder sphere of the shipped spreading cases
  // (Ti-6Al-4V cut at 20-60 um): the limit depends on the radii, not on where the spheres are.
  const std::filesystem::path state = BONDEM_TEST_TMPDIR "/time_step_limit_state.csv";
  std::filesystem::create_directories(state.parent_path());
  std::ofstream(state) << "id,x,y,z,vx,vy,vz,radius,material\n"
                       << "0,0.002,0.0005,0.0005,0,0,0,2.0e-5,ti64\n"
                       << "1,0.003,0.0005,0.0005,0,0,0,6.0e-5,ti64\n";
  for (const auto& entry : std::filesystem::recursive_directory_iterator(BONDEM_CASES_DIR)) {
    if (entry.path().extension() != ".yaml") continue;
    std::ostringstream text;
    text << std::ifstream(entry.path()).rdbuf();
    std::vector<std::string> overrides;
    if (text.str().find("\ninitial_state:") != std::string::npos) {
      overrides.push_back("initial_state.file=" + state.string());
    }
    const Case c = load_case(entry.path().string(), overrides);
    EXPECT_LE(c.time_step, case_time_step_limit(c)) << entry.path();
  }
  // scripts/paper-figures.sh: xi_bond up to 1 in example 5.1, xi_con 0.1 in example 5.2.
  Case fig1 = paper_case();
  fig1.contact.bond.damping_ratio = 1.0;
  EXPECT_LE(fig1.time_step, case_time_step_limit(fig1));
  // Example 5.2's densities run through collide, whose speeds (up to 12 m/s) are not the case's:
  // there the dampers' share of the limit must hold (the accuracy rule only warns).
  Case fig3 = load_case(BONDEM_CASES_DIR "/paper_5_2.yaml");
  fig3.contact.damping_ratio = 0.1;
  for (const double density : {500.0, 8000.0}) {
    fig3.materials[0].density = density;
    const PairReport r = compute_pair_report(fig3, 0, 1e-3, 0, 1e-3, 12.0);
    EXPECT_LE(fig3.time_step, std::min(r.contact_damper_step, r.bond_damper_step)) << density;
  }
}

TEST(CaseLimit, ToolSpeedEntersTheLimit) {
  Case c = load_case(BONDEM_CASES_DIR "/powder_spreading_ci.yaml");
  const auto blade = std::find_if(c.boundaries.begin(), c.boundaries.end(),
                                  [](const Boundary& b) { return b.motion.moves(); });
  ASSERT_NE(blade, c.boundaries.end());
  const double before = case_time_step_limit(c);
  blade->motion.keys.back().velocity.x() = 1e5;
  EXPECT_GE(reference_impact_speed(c), 2e5);
  const TimeStepLimit limit = case_time_step_bound(c);
  EXPECT_LT(limit.step, 1e-3 * before);
  EXPECT_NE(limit.cause.find("tool '" + blade->name + "'"), std::string::npos) << limit.cause;
  // A roller's rim speed counts like translation.
  Boundary roller;
  roller.shape = CylinderShape{Eigen::Vector3d::UnitY(), 0.01};
  roller.motion.axis = Eigen::Vector3d::UnitY();
  roller.motion.spin = 100.0;
  roller.motion.keys.push_back({0.0, Eigen::Vector3d(0.5, 0.0, 0.0)});
  EXPECT_DOUBLE_EQ(tool_surface_speed(roller), 1.5);
}

TEST(CaseLimit, UnphysicalSpeedIsAnErrorNamingTheParticle) {
  Case c = paper_case();
  c.particles.edit(1).velocity.x() = -1e300;
  try {
    case_time_step_bound(c);
    FAIL() << "accepted a speed of 1e300 m/s";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'particles.1.velocity'"), std::string::npos) << e.what();
  }
}

TEST(BlowUp, NonFiniteTemperatureNamesTheParticles) {
  Case c = load_case(BONDEM_CASES_DIR "/laser_sintering_ci.yaml");
  c.laser.reset();
  c.particles.edit(3).temperature = std::numeric_limits<double>::infinity();
  Scene scene = build_scene(c);
  Stepper stepper(scene);
  try {
    for (int s = 0; s < 3; ++s) stepper.step();
    FAIL() << "an infinite temperature went unnoticed";
  } catch (const BlowUpError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("non-finite temperature of"), std::string::npos) << what;
    EXPECT_EQ(e.cause(), BlowUpCause::kHeat);  // the run's advice then points at the heat step
    // The ids follow "id": at least one digit.
    const std::size_t at = what.find("), id ");
    ASSERT_NE(at, std::string::npos) << what;
    EXPECT_TRUE(std::isdigit(static_cast<unsigned char>(what[at + 6]))) << what;
  }
}

TEST(Restitution, MatchesACollideRun) {
  // Below v_crit and without bonding the pair rebounds on damped Hertz alone. 2e-8 s steps give
  // over 1 000 steps per contact: the collide run is then exact to about 1e-4 in e.
  Case c = paper_case();
  c.contact.bond.criterion = BondCriterion::kNever;
  c.time_step = 2e-8;
  for (const double xi : {0.0, 0.05, 0.197, 0.5, 1.0}) {
    c.contact.damping_ratio = xi;
    const PairReport r = compute_pair_report(c, 0, 1e-3, 0, 1e-3, 1.0);
    for (const double v : {0.3, 1.0}) {
      EXPECT_NEAR(r.restitution, collide(c, v).restitution, 1e-3) << "xi " << xi << " v " << v;
    }
  }
}

}  // namespace
}  // namespace bondem
