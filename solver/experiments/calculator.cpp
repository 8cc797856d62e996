#include "solver/experiments/calculator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include "solver/engine/scene.hpp"
#include "solver/models/pair.hpp"
#include "solver/setup/message_number.hpp"

namespace bondem {

double critical_velocity(double e_star, double r_star, double m_star, double critical_overlap) {
  const double scale = std::pow(16.0 * e_star * std::sqrt(r_star) / (15.0 * m_star), 0.4);
  return std::pow(scale * critical_overlap, 1.25);
}

double rayleigh_time(double radius, const Material& material) {
  const double shear_modulus = material.youngs_modulus / (2.0 * (1.0 + material.poisson_ratio));
  return std::numbers::pi * radius * std::sqrt(material.density / shear_modulus) /
         (0.1631 * material.poisson_ratio + 0.8766);
}

double damped_stability_step(double stiffness, double mass, double damping_ratio) {
  const double omega = std::sqrt(stiffness / mass);
  // 2 / (sqrt(1 + xi^2) + xi): no cancellation for large xi, and no overflow up to xi ~ 1e308.
  return 2.0 / (omega * (std::hypot(1.0, damping_ratio) + damping_ratio));
}

double damper_time_step(double stiffness, double mass, double damping_ratio) {
  return damped_stability_step(kPackingModeFactor * stiffness, mass,
                               std::sqrt(kPackingModeFactor) * damping_ratio);
}

double recommended_time_step(double contact_time, double bond_period, double rayleigh,
                             double damper_step) {
  return std::min({contact_time / kStepsPerOscillation, bond_period / kStepsPerOscillation,
                   kRayleighStepFraction * rayleigh, damper_step});
}

PairReport compute_pair_report(const Case& description, int material_a, double radius_a,
                               int material_b, double radius_b, double reference_velocity) {
  if (!(description.contact_model(material_a, material_b).bond.alpha >= 0.0 &&
        description.contact_model(material_a, material_b).bond.alpha < 1.5)) {
    std::ostringstream message;
    message << "bond.alpha = " << description.contact_model(material_a, material_b).bond.alpha
            << " is outside [0, 1.5): the bond is unstable unless the contact exponent 3/2 exceeds"
               " the adhesion exponent (eq. 9, 14)";
    throw std::invalid_argument(message.str());
  }
  if (!(radius_a > 0.0 && radius_b > 0.0 && reference_velocity > 0.0)) {
    throw std::invalid_argument("radii and reference velocity must be positive");
  }
  const Material& a = description.materials.at(static_cast<std::size_t>(material_a));
  const Material& b = description.materials.at(static_cast<std::size_t>(material_b));
  const PairCoefficients coefficients = description.pair_coefficients(material_a, material_b);
  const double r_star = effective_radius(radius_a, radius_b);
  const double m_star =
      effective_mass(sphere_mass(radius_a, a.density), sphere_mass(radius_b, b.density));
  const BondPair pair = make_bond_pair(coefficients, r_star, m_star);
  const double e_star = coefficients.effective_modulus;

  PairReport report{};
  report.effective_modulus = e_star;
  report.effective_radius = r_star;
  report.effective_mass = m_star;
  report.adhesion_stiffness = pair.adhesion_stiffness;
  report.equilibrium_overlap = pair.equilibrium_overlap;
  report.critical_overlap = pair.critical_overlap;
  report.critical_velocity = critical_velocity(e_star, r_star, m_star, pair.critical_overlap);
  // Without bonding there is no bond oscillation to resolve.
  report.bonding = coefficients.criterion != BondCriterion::kNever;
  report.reference_velocity = reference_velocity;
  // The time scales are the normal-force law's: the rule below has no branch per law.
  const NormalTimeScales scales = with_normal_law(description.normal_law, [&](const auto& law) {
    return law.time_scales(coefficients, r_star, m_star, reference_velocity, report.bonding);
  });
  report.impact = scales.impact;
  report.bond_stiffness = scales.oscillation_stiffness;
  report.bond_period = scales.oscillation_period;
  report.max_overlap = scales.impact_overlap;
  report.contact_time = scales.contact_time;
  report.rayleigh_time = std::min(rayleigh_time(radius_a, a), rayleigh_time(radius_b, b));
  report.contact_stiffness = scales.contact_stiffness;
  report.contact_damper_step =
      damper_time_step(scales.contact_stiffness, m_star, scales.contact_damping);
  report.bond_damper_step =
      std::isinf(scales.oscillation_period)
          ? std::numeric_limits<double>::infinity()
          : damper_time_step(scales.oscillation_stiffness, m_star, scales.oscillation_damping);
  report.restitution = restitution_of(description.normal_law, coefficients.contact_damping);
  report.recommended_time_step =
      recommended_time_step(report.contact_time, report.bond_period, report.rayleigh_time,
                            std::min(report.contact_damper_step, report.bond_damper_step));
  return report;
}

std::vector<std::string> time_step_warnings(const PairReport& report, double time_step) {
  std::vector<std::string> warnings;
  const auto check = [&](double duration, const char* what) {
    const double steps = duration / time_step;
    if (steps < kMinStepsPerContact) {
      std::ostringstream message;
      message << "time.step = " << time_step << " s resolves " << what << " in only " << steps
              << " steps (fewer than " << kMinStepsPerContact
              << "); recommended time step: " << report.recommended_time_step << " s";
      warnings.push_back(message.str());
    }
  };
  check(report.contact_time, "a Hertz impact");
  check(report.bond_period, "a bond oscillation");
  const auto check_damper = [&](double stable_step, const char* which) {
    if (time_step <= stable_step) return;
    std::ostringstream message;
    message << "time.step = " << time_step << " s is above the stable step of the " << which
            << " damper, " << stable_step
            << " s: the damper can amplify motion; recommended time step: "
            << report.recommended_time_step << " s";
    warnings.push_back(message.str());
  };
  check_damper(report.contact_damper_step, "contact");
  check_damper(report.bond_damper_step, "bond");
  return warnings;
}

double tool_surface_speed(const Boundary& tool) {
  const double rim = rotation_speed(tool);
  double fastest = 0.0;
  for (const MotionKey& key : tool.motion.keys) {
    fastest = std::max(fastest, key.velocity.stableNorm());
  }
  return fastest + rim;
}

namespace {

/// Index of the case's fastest particle (0 when none moves).
std::size_t fastest_particle(const Case& c) {
  // Each particle read once (a lattice block computes it on every read) and its speed measured
  // once: the first of the fastest, a NaN never counted faster.
  std::size_t fastest = 0;
  double fastest_speed = 0.0;
  std::size_t i = 0;
  for (const ParticleSpec& particle : c.particles) {
    // stableNorm: a speed of 1e300 is found as such, not as inf. Resting particles (a lattice
    // of 10^6 at rest took 20 ms of stableNorm per walk) skip it: their speed is exactly 0.
    const double speed = particle.velocity.isZero(0.0) ? 0.0 : particle.velocity.stableNorm();
    if (i == 0 || speed > fastest_speed) {
      fastest = i;
      fastest_speed = speed;
    }
    ++i;
  }
  return fastest;
}

/// Refuses a speed that is not finite or beyond the speed of light (no physical input gives one,
/// and the Hertz quantities of v^2 overflow further up), naming the particle or tool behind it.
void require_physical_speeds(const Case& c) {
  const auto refuse = [&](const std::string& what, double speed) {
    throw std::invalid_argument(c.source + ": " + what + " moves at " + message_number(speed) +
                                " m/s, which is not physical (above the speed of light)");
  };
  if (!c.particles.empty()) {
    const std::size_t i = fastest_particle(c);
    const double speed = c.particles[i].velocity.stableNorm();
    if (!(speed <= kSpeedOfLight)) {
      refuse("particle " + std::to_string(i) + " ('particles." + std::to_string(i) +
                 ".velocity' if listed, else its insert block)",
             speed);
    }
  }
  for (const Boundary& tool : c.boundaries) {
    const double speed = tool_surface_speed(tool);
    if (!(speed <= kSpeedOfLight)) refuse("tool '" + tool.name + "' (motion or spin)", speed);
  }
  const double fall = reference_impact_speed(c);
  if (!(fall <= 2.0 * kSpeedOfLight)) refuse("a fall across the domain under gravity", fall);
}

/// Keeps the smaller of two limits.
void tighten(TimeStepLimit& limit, double step, const std::string& cause) {
  if (step < limit.step || std::isnan(step)) limit = {step, cause};
}

}  // namespace

double reference_impact_speed(const Case& c) {
  double fastest =
      c.particles.empty() ? 0.0 : c.particles[fastest_particle(c)].velocity.stableNorm();
  for (const StreamInsertion& s : c.streams) fastest = std::max(fastest, s.velocity.stableNorm());
  double speed = 2.0 * fastest;
  for (const Boundary& tool : c.boundaries) {
    speed = std::max(speed, 2.0 * tool_surface_speed(tool));
  }
  const double g = c.gravity.norm();
  if (g > 0.0 && (c.domain || !c.particles.empty())) {
    Eigen::Vector3d lo, hi;
    if (c.domain) {
      lo = c.domain->min;
      hi = c.domain->max;
    } else {
      lo = hi = c.particles.front().position;
      for (const ParticleSpec& p : c.particles) {
        lo = lo.cwiseMin(p.position);
        hi = hi.cwiseMax(p.position);
      }
    }
    const double drop = std::abs((hi - lo).dot(c.gravity / g));
    speed = std::max(speed, std::sqrt(2.0 * g * drop));
  }
  return speed == 0.0 ? 1.0 : speed;  // nothing moves yet: a gentle 1 m/s contact as yardstick
}

TimeStepLimit case_time_step_bound(const Case& c) {
  std::vector<double> smallest(c.materials.size(), 0.0);
  double smallest_radius = std::numeric_limits<double>::infinity();
  const auto note = [&](int material, double radius) {
    double& r = smallest[static_cast<std::size_t>(material)];
    r = r == 0.0 ? radius : std::min(r, radius);
    smallest_radius = std::min(smallest_radius, radius);
  };
  for (const ParticleSpec& p : c.particles) note(p.material, p.radius);
  for (const StreamInsertion& s : c.streams) note(s.material, bondem::smallest_radius(s.radius));
  require_physical_speeds(c);
  const double speed = reference_impact_speed(c);
  TimeStepLimit limit{std::numeric_limits<double>::infinity(), "nothing"};
  const std::size_t n = c.materials.size();
  const auto name_of = [&](std::size_t m) { return c.materials[m].name; };
  for (std::size_t a = 0; a < n; ++a) {
    for (std::size_t b = a; b < n; ++b) {
      if (smallest[a] == 0.0 || smallest[b] == 0.0) continue;
      const PairReport r = compute_pair_report(c, static_cast<int>(a), smallest[a],
                                               static_cast<int>(b), smallest[b], speed);
      const std::string pair = " of [" + name_of(a) + " " + name_of(b) + "]";
      tighten(limit, r.contact_time / kStepsPerOscillation,
              "t_contact/50 of " + std::string(r.impact) + " at " + message_number(speed) + " m/s" +
                  pair);
      tighten(limit, r.bond_period / kStepsPerOscillation, "T_bond/50" + pair);
      tighten(limit, kRayleighStepFraction * r.rayleigh_time, "0.2 T_Rayleigh" + pair);
      const PairCoefficients coefficients =
          c.pair_coefficients(static_cast<int>(a), static_cast<int>(b));
      tighten(limit, r.contact_damper_step,
              "the stability of the contact damper (contact.damping_ratio = " +
                  message_number(coefficients.contact_damping) + ")" + pair);
      tighten(limit, r.bond_damper_step,
              "the stability of the bond damper (bond.damping_ratio = " +
                  message_number(coefficients.bond_damping) + ")" + pair);
    }
  }
  // Walls and tools: a sphere of infinite radius and mass, r* = r and m* = m.
  const auto surface = [&](int material, const std::string& what) {
    for (std::size_t a = 0; a < n; ++a) {
      if (smallest[a] == 0.0) continue;
      const PairCoefficients coefficients = c.pair_coefficients(static_cast<int>(a), material);
      const double r = smallest[a];
      const double m = sphere_mass(r, c.materials[a].density);
      const NormalTimeScales scales = with_normal_law(c.normal_law, [&](const auto& law) {
        return law.time_scales(coefficients, r, m, speed, false);
      });
      tighten(limit, damper_time_step(scales.contact_stiffness, m, scales.contact_damping),
              "the stability of the contact damper (contact.damping_ratio = " +
                  message_number(coefficients.contact_damping) + ") of [" + name_of(a) + "] on " +
                  what);
    }
  };
  for (const Boundary& tool : c.boundaries) {
    if (!tool.motion.moves()) {
      surface(tool.material, "wall '" + tool.name + "'");
      continue;
    }
    surface(tool.material, "tool '" + tool.name + "'");
    const double tool_speed = tool_surface_speed(tool);
    if (tool_speed > 0.0 && std::isfinite(smallest_radius)) {
      tighten(limit, kMaxToolStepFraction * smallest_radius / tool_speed,
              "tool '" + tool.name + "' at " + message_number(tool_speed) + " m/s moving at most " +
                  message_number(kMaxToolStepFraction) + " of the smallest radius per step");
    }
  }
  if (!(limit.step > 0.0) || std::isnan(limit.step)) {
    throw std::invalid_argument(c.source + ": the time-step limit (" + limit.cause + ") is " +
                                message_number(limit.step) +
                                ", not a usable number: check the materials' density and "
                                "youngs_modulus, the radii and the damping ratios");
  }
  return limit;
}

double case_time_step_limit(const Case& c) {
  return case_time_step_bound(c).step;
}

}  // namespace bondem
