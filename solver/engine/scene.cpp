#include "solver/engine/scene.hpp"

#include <algorithm>
#include <numbers>
#include <stdexcept>
#include <variant>

#include "solver/models/heat_law.hpp"
#include "solver/setup/message_number.hpp"

namespace bondem {

double sphere_mass(double radius, double density) {
  return 4.0 / 3.0 * std::numbers::pi * radius * radius * radius * density;
}

PairCoefficients Case::pair_coefficients(int a, int b) const {
  const Material& m_a = materials[static_cast<std::size_t>(a)];
  const Material& m_b = materials[static_cast<std::size_t>(b)];
  const double e_star = effective_modulus(m_a.youngs_modulus, m_a.poisson_ratio, m_b.youngs_modulus,
                                          m_b.poisson_ratio);
  const double strength =
      bond.input == AdhesionInput::kStiffness ? bond.stiffness : bond.equilibrium_overlap;
  PairCoefficients c = make_pair_coefficients(e_star, contact_damping, bond.damping_ratio,
                                              bond.alpha, bond.input, strength);
  c.shear_modulus = effective_shear_modulus(m_a.youngs_modulus, m_a.poisson_ratio,
                                            m_b.youngs_modulus, m_b.poisson_ratio);
  c.friction = friction;
  c.rolling_friction = rolling_friction;
  c.conductivity = harmonic_conductivity(m_a.thermal_conductivity, m_b.thermal_conductivity);
  return c;
}

NormalLawSpec normal_law_of(const Case& description) {
  if (const auto* bond = std::get_if<BondLawSpec>(&description.normal_law);
      bond != nullptr && !(bond->alpha == description.bond.alpha)) {
    throw std::invalid_argument(description.source + ": the bond law's alpha (" +
                                message_number(bond->alpha) + ") differs from bond.alpha (" +
                                message_number(description.bond.alpha) +
                                "): set both (Case::normal_law and Case::bond)");
  }
  return description.normal_law;
}

Scene build_scene(const Case& description) {
  Scene scene;
  scene.material_count = static_cast<int>(description.materials.size());
  for (int a = 0; a < scene.material_count; ++a) {
    for (int b = 0; b < scene.material_count; ++b) {
      scene.pair_table.push_back(description.pair_coefficients(a, b));
    }
  }
  scene.normal_law = normal_law_of(description);
  scene.criterion = description.bond.criterion;
  scene.gravity = description.gravity;
  scene.time_step = description.time_step;
  scene.walls = description.walls;
  double max_radius = 0.0;
  for (const ParticleSpec& spec : description.particles)
    max_radius = std::max(max_radius, spec.radius);
  scene.skin = verlet_skin(description, max_radius);
  scene.reorder_interval = description.reorder_interval;
  scene.max_overlap_fraction = description.max_overlap_fraction;
  if (description.domain) {
    scene.domain = *description.domain;
  } else if (!description.particles.empty()) {
    // Padded bounding box: only sizes the cell grid, particles may still leave it.
    Eigen::Vector3d lo = description.particles.front().position;
    Eigen::Vector3d hi = lo;
    for (const ParticleSpec& spec : description.particles) {
      lo = lo.cwiseMin(spec.position);
      hi = hi.cwiseMax(spec.position);
    }
    const double pad = 4.0 * max_radius + scene.skin;
    scene.domain.min = lo.array() - pad;
    scene.domain.max = hi.array() + pad;
  }
  scene.friction = description.friction > 0.0 || description.rolling_friction > 0.0;
  scene.bodies = description.bodies;
  scene.particles.set_wall_count(static_cast<int>(scene.walls.size() + scene.bodies.size()));
  std::int64_t next_id = 0;
  for (const ParticleSpec& spec : description.particles) {
    const double density = description.materials[static_cast<std::size_t>(spec.material)].density;
    scene.particles.add(next_id++, spec.material, spec.radius, sphere_mass(spec.radius, density),
                        spec.position.data(), spec.velocity.data());
  }
  if (description.thermal) {
    const ThermalModel& thermal = *description.thermal;
    Particles& p = scene.particles;
    p.temperature.resize(p.size());
    p.inv_heat_capacity.resize(p.size());
    p.heat_rate.assign(p.size(), 0.0);
    for (std::size_t i = 0; i < p.size(); ++i) {
      const Material& m = description.materials[static_cast<std::size_t>(p.material[i])];
      p.temperature[i] = description.particles[i].temperature;
      p.inv_heat_capacity[i] = 1.0 / sphere_heat_capacity(p.mass[i], m.specific_heat);
    }
    p.peak_temperature = p.temperature;
    scene.ambient_temperature = thermal.ambient_temperature;
    scene.convection_coefficient = thermal.convection_coefficient;
    for (const Material& m : description.materials) {
      scene.emissivity.push_back(thermal.radiation ? m.emissivity : 0.0);
    }
    scene.bond_temperature = description.bond.temperature;
    scene.laser = description.laser;
  }
  return scene;
}

}  // namespace bondem
