#include "solver/calculator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include "solver/pair.hpp"
#include "solver/scene.hpp"

namespace bondem {

double hertz_max_overlap(double e_star, double r_star, double m_star, double velocity) {
  return std::pow(15.0 * m_star * velocity * velocity / (16.0 * e_star * std::sqrt(r_star)), 0.4);
}

double hertz_contact_time(double e_star, double r_star, double m_star, double velocity) {
  static const double integral = std::sqrt(std::numbers::pi) * std::tgamma(1.4) / std::tgamma(0.9);
  return 2.0 * integral * hertz_max_overlap(e_star, r_star, m_star, velocity) / velocity;
}

double critical_velocity(double e_star, double r_star, double m_star, double critical_overlap) {
  const double scale = std::pow(16.0 * e_star * std::sqrt(r_star) / (15.0 * m_star), 0.4);
  return std::pow(scale * critical_overlap, 1.25);
}

double rayleigh_time(double radius, const Material& material) {
  const double shear_modulus = material.youngs_modulus / (2.0 * (1.0 + material.poisson_ratio));
  return std::numbers::pi * radius * std::sqrt(material.density / shear_modulus) /
         (0.1631 * material.poisson_ratio + 0.8766);
}

double recommended_time_step(double contact_time, double bond_period, double rayleigh) {
  return std::min({contact_time / 50.0, bond_period / 50.0, 0.2 * rayleigh});
}

PairReport compute_pair_report(const Case& description, int material_a, double radius_a,
                               int material_b, double radius_b, double reference_velocity) {
  if (!(description.bond.alpha >= 0.0 && description.bond.alpha < 1.5)) {
    std::ostringstream message;
    message << "bond.alpha = " << description.bond.alpha
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
  const double alpha = coefficients.alpha;

  PairReport report{};
  report.effective_modulus = e_star;
  report.effective_radius = r_star;
  report.effective_mass = m_star;
  report.adhesion_stiffness = pair.adhesion_stiffness;
  report.equilibrium_overlap = pair.equilibrium_overlap;
  report.critical_overlap = pair.critical_overlap;
  report.critical_velocity = critical_velocity(e_star, r_star, m_star, pair.critical_overlap);
  // eq. 24 at delta_eq
  report.bond_stiffness =
      2.0 * e_star * std::sqrt(r_star * pair.equilibrium_overlap) -
      alpha * pair.adhesion_stiffness * std::pow(pair.equilibrium_overlap, alpha - 1.0);
  // Without bonding there is no bond oscillation to resolve.
  report.bond_period = description.bond.criterion == BondCriterion::kNever
                           ? std::numeric_limits<double>::infinity()
                           : 2.0 * std::numbers::pi * std::sqrt(m_star / report.bond_stiffness);
  report.reference_velocity = reference_velocity;
  report.max_overlap = hertz_max_overlap(e_star, r_star, m_star, reference_velocity);
  report.contact_time = hertz_contact_time(e_star, r_star, m_star, reference_velocity);
  report.rayleigh_time = std::min(rayleigh_time(radius_a, a), rayleigh_time(radius_b, b));
  report.recommended_time_step =
      recommended_time_step(report.contact_time, report.bond_period, report.rayleigh_time);
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
  return warnings;
}

double reference_impact_speed(const Case& c) {
  double fastest = 0.0;
  for (const ParticleSpec& p : c.particles) fastest = std::max(fastest, p.velocity.norm());
  double speed = 2.0 * fastest;
  const double g = c.gravity.norm();
  if (g > 0.0 && !c.particles.empty()) {
    Eigen::Vector3d lo = c.particles.front().position;
    Eigen::Vector3d hi = lo;
    for (const ParticleSpec& p : c.particles) {
      lo = lo.cwiseMin(p.position);
      hi = hi.cwiseMax(p.position);
    }
    if (c.domain) {
      lo = c.domain->min;
      hi = c.domain->max;
    }
    const double drop = std::abs((hi - lo).dot(c.gravity / g));
    speed = std::max(speed, std::sqrt(2.0 * g * drop));
  }
  return speed > 0.0 ? speed : 1.0;  // nothing moves yet: a gentle 1 m/s contact as yardstick
}

double case_time_step_limit(const Case& c) {
  std::vector<double> smallest(c.materials.size(), 0.0);
  for (const ParticleSpec& p : c.particles) {
    double& r = smallest[static_cast<std::size_t>(p.material)];
    r = r == 0.0 ? p.radius : std::min(r, p.radius);
  }
  const double speed = reference_impact_speed(c);
  double step = std::numeric_limits<double>::infinity();
  const std::size_t n = c.materials.size();
  for (std::size_t a = 0; a < n; ++a) {
    for (std::size_t b = a; b < n; ++b) {
      if (smallest[a] == 0.0 || smallest[b] == 0.0) continue;
      const PairReport r = compute_pair_report(c, static_cast<int>(a), smallest[a],
                                               static_cast<int>(b), smallest[b], speed);
      step = std::min(step, r.recommended_time_step);
    }
  }
  return step;
}

}  // namespace bondem
