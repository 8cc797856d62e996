#include "solver/engine/scene.hpp"

#include <algorithm>
#include <numbers>
#include <numeric>
#include <stdexcept>
#include <utility>
#include <variant>

#include "solver/engine/boundary_candidates.hpp"
#include "solver/models/contact_laws.hpp"
#include "solver/models/heat_law.hpp"
#include "solver/setup/message_number.hpp"

namespace bondem {

double sphere_mass(double radius, double density) {
  return 4.0 / 3.0 * std::numbers::pi * radius * radius * radius * density;
}

const ContactModel& Case::contact_model(int a, int b) const {
  for (const Interaction& entry : interactions) {
    if (entry.joins(a, b)) return entry.model;
  }
  return contact;
}

PairCoefficients Case::pair_coefficients(int a, int b) const {
  const Material& m_a = materials[static_cast<std::size_t>(a)];
  const Material& m_b = materials[static_cast<std::size_t>(b)];
  const ContactModel& model = contact_model(a, b);
  const BondModel& bond = model.bond;
  const double e_star = effective_modulus(m_a.youngs_modulus, m_a.poisson_ratio, m_b.youngs_modulus,
                                          m_b.poisson_ratio);
  const double strength =
      bond.input == AdhesionInput::kStiffness ? bond.stiffness : bond.equilibrium_overlap;
  const double xi_con = model.restitution > 0.0 ? damping_ratio_of(normal_law, model.restitution)
                                                : model.damping_ratio;
  PairCoefficients c =
      make_pair_coefficients(e_star, xi_con, bond.damping_ratio, bond.alpha, bond.input, strength);
  c.restitution = model.restitution;
  c.shear_modulus = effective_shear_modulus(m_a.youngs_modulus, m_a.poisson_ratio,
                                            m_b.youngs_modulus, m_b.poisson_ratio);
  c.friction = model.friction;
  c.rolling_friction = model.rolling_friction;
  c.rolling_model = model.rolling_model;
  c.rolling_damping = model.rolling_damping;
  c.cohesion = model.cohesion;
  c.cohesion_energy = model.cohesion_energy;
  c.criterion = bond.criterion;
  c.bond_temperature = bond.temperature;
  c.conductivity = harmonic_conductivity(m_a.thermal_conductivity, m_b.thermal_conductivity);
  return c;
}

bool needs_contact_history(const std::vector<PairCoefficients>& table) {
  return std::any_of(table.begin(), table.end(), [](const PairCoefficients& c) {
    return c.cohesion != CohesionModel::kNone ||
           (c.rolling_model == RollingModel::kEpsd && c.rolling_friction > 0.0);
  });
}

namespace {

/// Largest distance beyond touching at which a JKR contact of @p table still holds, for particles
/// of radius up to @p max_radius (a particle on a boundary has r* = r, the largest r*).
double cohesion_range(const std::vector<PairCoefficients>& table, double max_radius) {
  double range = 0.0;
  for (const PairCoefficients& c : table) {
    range = std::max(range, -separation_overlap(c, max_radius));
  }
  return range;
}

}  // namespace

namespace {

/// The id after the largest id given in @p description's list (0 when none is) and how many
/// particles have none: those take the ids from there on, in list order.
std::pair<std::int64_t, std::int64_t> free_ids(const Case& description) {
  std::int64_t first_free = 0;
  std::int64_t unassigned = 0;
  for (const ParticleSpec& spec : description.particles) {
    first_free = std::max(first_free, spec.id + 1);
    unassigned += spec.id < 0 ? 1 : 0;
  }
  return {first_free, unassigned};
}

}  // namespace

std::vector<std::int64_t> particle_ids(const Case& description,
                                       const std::vector<std::uint32_t>& chosen) {
  // One walk through the list in index order, counting the particles without an id.
  std::vector<std::uint32_t> by_index(chosen.size());
  std::iota(by_index.begin(), by_index.end(), 0U);
  if (!std::is_sorted(chosen.begin(), chosen.end())) {
    std::sort(by_index.begin(), by_index.end(),
              [&](std::uint32_t a, std::uint32_t b) { return chosen[a] < chosen[b]; });
  }
  std::int64_t next_free = free_ids(description).first;
  std::vector<std::int64_t> ids(chosen.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < description.particles.size() && k < by_index.size(); ++i) {
    const std::int64_t id = description.particles[i].id;
    for (; k < by_index.size() && chosen[by_index[k]] == i; ++k) {
      ids[by_index[k]] = id >= 0 ? id : next_free;
    }
    if (id < 0) ++next_free;
  }
  return ids;
}

std::int64_t next_particle_id(const Case& description) {
  const auto [first_free, unassigned] = free_ids(description);
  return first_free + unassigned;
}

Scene build_scene(const Case& description) {
  std::vector<std::uint32_t> every(description.particles.size());
  std::iota(every.begin(), every.end(), 0U);
  return build_scene(description, every);
}

Scene build_scene(const Case& description, const std::vector<std::uint32_t>& chosen) {
  Scene scene;
  scene.material_count = static_cast<int>(description.materials.size());
  for (const Material& m : description.materials) scene.material_names.push_back(m.name);
  for (int a = 0; a < scene.material_count; ++a) {
    for (int b = 0; b < scene.material_count; ++b) {
      scene.pair_table.push_back(description.pair_coefficients(a, b));
    }
  }
  scene.normal_law = description.normal_law;
  scene.gravity = description.gravity;
  scene.time_step = description.time_step;
  const double max_radius = largest_radius(description);
  scene.largest_radius = max_radius;
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
  scene.friction = std::any_of(
      scene.pair_table.begin(), scene.pair_table.end(),
      [](const PairCoefficients& c) { return c.friction > 0.0 || c.rolling_friction > 0.0; });
  scene.contact_range = cohesion_range(scene.pair_table, max_radius);
  scene.particles.contact_history = needs_contact_history(scene.pair_table);
  // VTK frames are the displacement's one reader: without them it costs 24 B a particle for
  // nothing.
  scene.particles.displacement_tracked = description.vtk_interval > 0.0;
  scene.boundaries = description.boundaries;
  int slots = 0;
  for (Boundary& boundary : scene.boundaries) {
    scene.first_slot.push_back(slots);
    int count = 1;
    if (auto* mesh = std::get_if<MeshShape>(&boundary.shape)) {
      count = kMeshContactSlots;
      scene.particles.mesh_contacts = true;
      // Cells as wide as a candidate query (boundary_candidates.hpp): it then meets at most
      // 2 x 2 x 2 cells.
      const double cell =
          2.0 * (max_radius + scene.contact_range + kBoundaryCandidateMargin * scene.skin);
      mesh->surface = make_mesh_surface(mesh->surface->mesh, cell, mesh->surface->file);
    }
    scene.slot_count.push_back(count);
    slots += count;
  }
  scene.particles.set_wall_count(slots);
  // Every array sized once and filled on every thread: adding 10^6 particles one at a time, each
  // page cleared by the kernel on one thread, was a tenth of the set-up of a 10^6 lattice.
  const ParticleList& specs = description.particles;
  const std::size_t n = chosen.size();
  Particles& p = scene.particles;
  p.assign_zeros(n);
  const std::vector<std::int64_t> ids = particle_ids(description, chosen);
  for (std::size_t i = 0; i < n; ++i) p.id[i] = ids[i];
#pragma omp parallel for schedule(static) if (n >= kMinParallelParticles)
  for (std::size_t i = 0; i < n; ++i) {
    const ParticleSpec spec = specs[chosen[i]];
    const double density = description.materials[static_cast<std::size_t>(spec.material)].density;
    p.material[i] = spec.material;
    p.radius[i] = spec.radius;
    p.mass[i] = sphere_mass(spec.radius, density);
    p.x[i] = spec.position.x();
    p.y[i] = spec.position.y();
    p.z[i] = spec.position.z();
    p.vx[i] = spec.velocity.x();
    p.vy[i] = spec.velocity.y();
    p.vz[i] = spec.velocity.z();
    p.wx[i] = spec.angular_velocity.x();
    p.wy[i] = spec.angular_velocity.y();
    p.wz[i] = spec.angular_velocity.z();
  }
  scene.initial_pairs = description.initial_pairs;
  for (const StreamInsertion& stream : description.streams) {
    const Material& m = description.materials[static_cast<std::size_t>(stream.material)];
    scene.streams.push_back({stream, m.density, m.specific_heat});
  }
  if (description.thermal) {
    const ThermalModel& thermal = *description.thermal;
    p.track_temperatures();
    for (std::size_t i = 0; i < p.size(); ++i) {
      const Material& m = description.materials[static_cast<std::size_t>(p.material[i])];
      p.temperature[i] = specs[chosen[i]].temperature;
      p.inv_heat_capacity[i] = 1.0 / sphere_heat_capacity(p.mass[i], m.specific_heat);
    }
    p.peak_temperature = p.temperature;
    scene.ambient_temperature = thermal.ambient_temperature;
    scene.convection_coefficient = thermal.convection_coefficient;
    for (const Material& m : description.materials) {
      scene.emissivity.push_back(thermal.radiation ? m.emissivity : 0.0);
    }
    scene.laser = description.laser;
  }
  return scene;
}

}  // namespace bondem
