#pragma once
/// @file contact_kernel.hpp
/// Force kernels: evaluate the laws per candidate pair and per wall, then gather per particle.
///
/// Race-free and thread-count independent without atomics: pass 1 writes each pair's force into
/// its own slot; pass 2 sums, for each particle, its own row then its transposed row, in list
/// order. Every particle's sum therefore has one fixed order whatever the thread count.

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <vector>

#include "geometry/bodies.hpp"
#include "geometry/walls.hpp"
#include "solver/engine/neighbor_list.hpp"
#include "solver/engine/scene.hpp"
#include "solver/models/bond_law.hpp"
#include "solver/models/heat_law.hpp"
#include "solver/models/pair.hpp"
#include "solver/models/rolling_law.hpp"
#include "solver/models/tangential_law.hpp"

namespace bondem {

/// What a force evaluation saw.
struct ContactSummary {
  std::size_t contacts = 0;           ///< particle pairs with positive overlap
  std::size_t bonds = 0;              ///< contacts on the adhesive branch of eq. 25
  std::size_t wall_contacts = 0;      ///< particle-wall contacts
  double max_overlap = 0.0;           ///< largest overlap of any contact [m]
  double max_overlap_fraction = 0.0;  ///< largest overlap / radius of the smaller body
  std::size_t bonds_formed = 0;       ///< pairs that joined the adhesive branch this evaluation
  std::size_t bonds_broken = 0;       ///< pairs that left it (overlap at delta_crit, or apart)
  /// Largest dt sum(H) / (m c_p) of any particle; above 1 the explicit heat step is unstable.
  double thermal_step_ratio = 0.0;
};

/// Per-pair forces on the first particle of each pair, one slot per neighbor-list entry.
///
/// Torques are stored in 4 values per pair, not 6: the tangential force F_t acts at the middle of
/// the overlap, at lever r_i - delta/2 along n from centre i and r_j - delta/2 along -n from j, so
/// both torques are (lever length) x (n x F_t). Pass 2 multiplies n x F_t by its own particle's
/// lever. Rolling torque (+ on i, - on j) takes 3 more only where the scene has rolling resistance.
struct PairForces {
  std::vector<double> fx, fy, fz;
  std::vector<std::uint8_t> bonded;            ///< 1 where the pair is on the adhesive branch
  std::vector<double> cx, cy, cz;              ///< n x F_t: torque per metre of lever (friction)
  std::vector<double> half_overlap;            ///< delta / 2, which shortens both levers (friction)
  std::vector<double> roll_x, roll_y, roll_z;  ///< rolling torque on i (rolling resistance)
  std::vector<double> heat;                    ///< heat flow into i [W] (thermal runs)
  std::vector<double> conductance;             ///< contact conductance H [W/K] (thermal runs)
  void resize(std::size_t pairs, bool torques, bool rolling, bool thermal) {
    for (std::vector<double>* f : {&fx, &fy, &fz}) f->resize(pairs);
    bonded.resize(pairs);
    for (std::vector<double>* t : {&cx, &cy, &cz, &half_overlap}) t->resize(torques ? pairs : 0);
    for (std::vector<double>* t : {&roll_x, &roll_y, &roll_z}) {
      t->resize(torques && rolling ? pairs : 0);
    }
    heat.resize(thermal ? pairs : 0);
    conductance.resize(thermal ? pairs : 0);
  }
};

/// Tangential spring elongation of every candidate pair, indexed like the neighbor list. It is
/// carried across list rebuilds by particle ids (see Stepper), so reordering never loses it.
struct PairHistory {
  std::vector<double> sx, sy, sz;
  void resize(std::size_t pairs) {
    for (std::vector<double>* s : {&sx, &sy, &sz}) s->assign(pairs, 0.0);
  }
};

/// Pass 1: the bond law for every candidate pair of @p list (force on i stored; j gets minus).
/// @param criterion_met callable (i, j, k) -> bool, the bonding criterion of pair k = (i, j); it
/// may read out.bonded[k], which still holds the pair's previous state.
/// In thermal runs each contact also gets its conductance and the heat flow into i.
/// With kFriction the pair also gets the tangential law (history in @p history) and rolling
/// resistance, and torques are stored; without it that code is compiled out.
template <bool kFriction, class Adhesion, class Criterion>
ContactSummary compute_pair_forces(const Particles& p, const Scene& scene, const NeighborList& list,
                                   Adhesion adhesion, Criterion criterion_met, PairForces& out,
                                   PairHistory& history) {
  const std::size_t n = p.size();
  std::size_t contacts = 0;
  std::size_t bonds = 0;
  std::size_t formed = 0;
  std::size_t broken = 0;
  double max_overlap = 0.0;
  double max_fraction = 0.0;
  const bool thermal = p.thermal();
  const bool rolling = kFriction && !out.roll_x.empty();
  // Pairs go in blocks: a short first loop takes every pair's distance (a square root and a
  // division per pair, independent across pairs, so they overlap in the pipeline), then the laws
  // run on the stored geometry. One long loop body would serialise those latencies.
  constexpr std::size_t kChunk = 64;     // particles per scheduling unit
  constexpr std::uint32_t kBlock = 128;  // pairs per geometry block
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
#pragma omp parallel for schedule(static) if (n >= kMinParallelParticles) \
    reduction(+ : contacts, bonds, formed, broken) reduction(max : max_overlap, max_fraction)
  for (std::size_t chunk = 0; chunk < chunks; ++chunk) {
    std::uint32_t first_of[kBlock];
    double overlap_of[kBlock], nx_of[kBlock], ny_of[kBlock], nz_of[kBlock];
    double r_star_of[kBlock], m_star_of[kBlock];
    const std::size_t chunk_end = std::min(n, (chunk + 1) * kChunk);
    std::size_t row = chunk * kChunk;
    const std::uint32_t pairs_end = list.row_begin[chunk_end];
    for (std::uint32_t block = list.row_begin[row]; block < pairs_end; block += kBlock) {
      const std::uint32_t block_end = std::min(pairs_end, block + kBlock);
      for (std::uint32_t k = block; k < block_end; ++k) {
        while (list.row_begin[row + 1] <= k) ++row;
        const std::size_t i = row;
        const std::size_t j = list.second[k];
        const Eigen::Vector3d& shift = list.shifts[list.image[k]];
        const double dx = p.x[j] - p.x[i] + shift.x();
        const double dy = p.y[j] - p.y[i] + shift.y();
        const double dz = p.z[j] - p.z[i] + shift.z();
        const double distance = std::sqrt(dx * dx + dy * dy + dz * dz);
        const double inv_distance = 1.0 / distance;
        first_of[k - block] = static_cast<std::uint32_t>(i);
        overlap_of[k - block] = p.radius[i] + p.radius[j] - distance;
        nx_of[k - block] = dx * inv_distance;
        ny_of[k - block] = dy * inv_distance;
        nz_of[k - block] = dz * inv_distance;
        r_star_of[k - block] = effective_radius(p.radius[i], p.radius[j]);
        m_star_of[k - block] = effective_mass(p.mass[i], p.mass[j]);
      }
      for (std::uint32_t k = block; k < block_end; ++k) {
        const std::size_t i = first_of[k - block];
        const std::size_t j = list.second[k];
        const double overlap = overlap_of[k - block];
        if (!(overlap > 0.0)) {
          out.fx[k] = out.fy[k] = out.fz[k] = 0.0;
          broken += out.bonded[k];
          out.bonded[k] = 0;
          if (thermal) out.heat[k] = out.conductance[k] = 0.0;
          if constexpr (kFriction) {
            out.cx[k] = out.cy[k] = out.cz[k] = out.half_overlap[k] = 0.0;
            if (rolling) out.roll_x[k] = out.roll_y[k] = out.roll_z[k] = 0.0;
            history.sx[k] = history.sy[k] = history.sz[k] = 0.0;  // contact lost: spring released
          }
          continue;
        }
        const double nx = nx_of[k - block];
        const double ny = ny_of[k - block];
        const double nz = nz_of[k - block];
        const double overlap_rate =
            -((p.vx[j] - p.vx[i]) * nx + (p.vy[j] - p.vy[i]) * ny + (p.vz[j] - p.vz[i]) * nz);
        const PairCoefficients& coefficients = scene.pair(p.material[i], p.material[j]);
        const double r_star = r_star_of[k - block];
        const double m_star = m_star_of[k - block];
        const BondPair law = make_bond_pair(coefficients, r_star, m_star);
        const NormalForce f =
            normal_force(law, adhesion, overlap, overlap_rate, criterion_met(i, j, k));
        out.fx[k] = f.force * nx;
        out.fy[k] = f.force * ny;
        out.fz[k] = f.force * nz;
        formed += f.bonded && out.bonded[k] == 0 ? 1 : 0;
        broken += !f.bonded && out.bonded[k] != 0 ? 1 : 0;
        out.bonded[k] = f.bonded ? 1 : 0;
        if (thermal) {
          const double h =
              spot_conductance(coefficients.conductivity, std::sqrt(r_star) * std::sqrt(overlap));
          out.conductance[k] = h;
          out.heat[k] = h * (p.temperature[j] - p.temperature[i]);
        }
        if constexpr (kFriction) {
          const Eigen::Vector3d normal(nx, ny, nz);
          // Levers from each centre to the contact point, the middle of the overlap.
          const Eigen::Vector3d lever_i = (p.radius[i] - 0.5 * overlap) * normal;
          const Eigen::Vector3d lever_j = -(p.radius[j] - 0.5 * overlap) * normal;
          const Eigen::Vector3d spin_i(p.wx[i], p.wy[i], p.wz[i]);
          const Eigen::Vector3d spin_j(p.wx[j], p.wy[j], p.wz[j]);
          const Eigen::Vector3d contact_velocity =
              Eigen::Vector3d(p.vx[j], p.vy[j], p.vz[j]) + spin_j.cross(lever_j) -
              Eigen::Vector3d(p.vx[i], p.vy[i], p.vz[i]) - spin_i.cross(lever_i);
          const Eigen::Vector3d sliding = contact_velocity - contact_velocity.dot(normal) * normal;
          const double k_t =
              mindlin_stiffness(coefficients.shear_modulus, std::sqrt(r_star) * std::sqrt(overlap));
          const double d_t = 2.0 * coefficients.contact_damping * std::sqrt(m_star * k_t);
          // A bond presses the surfaces together with its Hertz part even where the net normal
          // force vanishes (at delta_eq): that load, not the net force, limits its friction.
          const double load = f.bonded ? law.hertz_stiffness * overlap * std::sqrt(overlap)
                                       : std::max(0.0, -f.force);
          const TangentialForce t =
              tangential_force(k_t, d_t, coefficients.friction, load, normal,
                               Eigen::Vector3d(history.sx[k], history.sy[k], history.sz[k]),
                               sliding, scene.time_step);
          history.sx[k] = t.slip.x();
          history.sy[k] = t.slip.y();
          history.sz[k] = t.slip.z();
          out.fx[k] += t.force.x();
          out.fy[k] += t.force.y();
          out.fz[k] += t.force.z();
          const Eigen::Vector3d per_lever = normal.cross(t.force);
          out.cx[k] = per_lever.x();
          out.cy[k] = per_lever.y();
          out.cz[k] = per_lever.z();
          out.half_overlap[k] = 0.5 * overlap;
          if (rolling) {
            // I* = I_i I_j / (I_i + I_j) = 1 / (1/I_i + 1/I_j)
            const Eigen::Vector3d roll =
                coefficients.rolling_friction == 0.0
                    ? Eigen::Vector3d::Zero()
                    : rolling_torque(coefficients.rolling_friction, r_star, load, spin_i - spin_j,
                                     1.0 / (p.inverse_inertia(i) + p.inverse_inertia(j)),
                                     scene.time_step);
            out.roll_x[k] = roll.x();
            out.roll_y[k] = roll.y();
            out.roll_z[k] = roll.z();
          }
        }
        ++contacts;
        bonds += f.bonded ? 1 : 0;
        max_overlap = std::max(max_overlap, overlap);
        max_fraction = std::max(max_fraction, overlap / std::min(p.radius[i], p.radius[j]));
      }
    }
  }
  ContactSummary summary;
  summary.contacts = contacts;
  summary.bonds = bonds;
  summary.bonds_formed = formed;
  summary.bonds_broken = broken;
  summary.max_overlap = max_overlap;
  summary.max_overlap_fraction = max_fraction;
  return summary;
}

/// Contact of particle i with a surface of material @p material: damped Hertz (r* = r_i,
/// m* = m_i: a wall or tool is a sphere of infinite radius and mass) and, with kFriction, the
/// tangential law (history in p.wall_slip slot @p slot) and rolling resistance.
/// @param gap centre-to-surface distance; @param normal unit, from the surface to the centre;
/// @param surface_velocity velocity of the surface material at the contact.
/// Returns the overlap (<= 0: no contact, zero force and torque, history released).
template <bool kFriction>
double surface_contact(Particles& p, const Scene& scene, int material, std::size_t slot,
                       std::size_t i, double gap, const Eigen::Vector3d& normal,
                       const Eigen::Vector3d& surface_velocity, Eigen::Vector3d& force,
                       Eigen::Vector3d& torque) {
  const double overlap = p.radius[i] - gap;
  double* slip =
      kFriction ? &p.wall_slip[(i * static_cast<std::size_t>(p.walls) + slot) * 3] : nullptr;
  torque.setZero();
  if (overlap <= 0.0) {
    force.setZero();
    if constexpr (kFriction) slip[0] = slip[1] = slip[2] = 0.0;
    return overlap;
  }
  const PairCoefficients& c = scene.pair(p.material[i], material);
  const BondPair law{hertz_stiffness(c.effective_modulus, p.radius[i]),
                     p.mass[i],
                     0.0,
                     0.0,
                     0.0,
                     c.contact_damping,
                     0.0};
  const Eigen::Vector3d velocity(p.vx[i], p.vy[i], p.vz[i]);
  const double overlap_rate = -(velocity - surface_velocity).dot(normal);
  // n_ij points from the particle into the surface, i.e. along -normal.
  const double f_n = hertz_contact_force(law, overlap, overlap_rate);
  force = -f_n * normal;
  if constexpr (kFriction) {
    const Eigen::Vector3d n_ij = -normal;
    const Eigen::Vector3d lever = (p.radius[i] - overlap) * n_ij;  // to the surface
    const Eigen::Vector3d spin(p.wx[i], p.wy[i], p.wz[i]);
    const Eigen::Vector3d contact_velocity = surface_velocity - (velocity + spin.cross(lever));
    const Eigen::Vector3d sliding = contact_velocity - contact_velocity.dot(n_ij) * n_ij;
    const double k_t =
        mindlin_stiffness(c.shear_modulus, std::sqrt(p.radius[i]) * std::sqrt(overlap));
    const double d_t = 2.0 * c.contact_damping * std::sqrt(p.mass[i] * k_t);
    const TangentialForce t =
        tangential_force(k_t, d_t, c.friction, -f_n, n_ij,
                         Eigen::Vector3d(slip[0], slip[1], slip[2]), sliding, scene.time_step);
    slip[0] = t.slip.x();
    slip[1] = t.slip.y();
    slip[2] = t.slip.z();
    force += t.force;
    torque = lever.cross(t.force) + rolling_torque(c.rolling_friction, p.radius[i], -f_n, spin,
                                                   1.0 / p.inverse_inertia(i), scene.time_step);
  }
  return overlap;
}

/// Contact of particle i with boundary @p b: the walls first, then the moving bodies. Returns the
/// overlap when positive; without contact, a value <= 0 (for a body far away, just 0).
template <bool kFriction>
double boundary_contact(Particles& p, const Scene& scene, std::size_t b, std::size_t i,
                        Eigen::Vector3d& force, Eigen::Vector3d& torque) {
  if (b < scene.walls.size()) {
    const PlaneWall& wall = scene.walls[b];
    return surface_contact<kFriction>(p, scene, wall.material, b, i,
                                      distance_to(wall, p.x[i], p.y[i], p.z[i]), wall.normal,
                                      Eigen::Vector3d::Zero(), force, torque);
  }
  const Body& body = scene.bodies[b - scene.walls.size()];
  const Eigen::Vector3d centre(p.x[i], p.y[i], p.z[i]);
  if (surely_apart(body, centre, p.radius[i])) {
    // Most particles are far from a tool: skip its exact distance and the law. The result is
    // that of surface_contact without contact; the overlap returned is only known to be <= 0.
    force.setZero();
    torque.setZero();
    if constexpr (kFriction) {
      double* slip = &p.wall_slip[(i * static_cast<std::size_t>(p.walls) + b) * 3];
      slip[0] = slip[1] = slip[2] = 0.0;
    }
    return 0.0;
  }
  const SurfacePoint surface = nearest_surface(body, centre);
  const Eigen::Vector3d point = centre - surface.gap * surface.normal;
  return surface_contact<kFriction>(p, scene, body.material, b, i, surface.gap, surface.normal,
                                    surface_velocity(body, point), force, torque);
}

/// Particles per block of the wall-load partial sums of gather_forces.
inline constexpr std::size_t kWallLoadBlock = 64;

/// Pass 2: total force (and, with kFriction, torque) per particle = gravity + own pairs -
/// transposed pairs + walls. The force of each wall on the particles is summed per block of
/// kWallLoadBlock particles into @p wall_forces (3 values per block and wall): the caller adds the
/// blocks in order, so wall loads need no per-particle storage and keep one summation order. In
/// thermal runs the same order sums the heat flows into p.heat_rate: contacts, walls held at a
/// temperature, convection and radiation (the laser is added by the caller).
template <bool kFriction>
ContactSummary gather_forces(Particles& p, const Scene& scene, const NeighborList& list,
                             const PairForces& pair_forces, std::vector<double>& wall_forces) {
  const std::size_t n = p.size();
  const std::size_t walls = scene.walls.size() + scene.bodies.size();
  const std::size_t blocks = (n + kWallLoadBlock - 1) / kWallLoadBlock;
  wall_forces.assign(blocks * walls * 3, 0.0);
  const Eigen::Vector3d g = scene.gravity;
  std::size_t wall_contacts = 0;
  double max_overlap = 0.0;
  double max_fraction = 0.0;
  double thermal_ratio = 0.0;
  const bool thermal = p.thermal();
  const bool rolling = kFriction && !pair_forces.roll_x.empty();
#pragma omp parallel for schedule(static) if (n >= kMinParallelParticles) \
    reduction(+ : wall_contacts) reduction(max : max_overlap, max_fraction, thermal_ratio)
  for (std::size_t block = 0; block < blocks; ++block) {
    double* block_load = wall_forces.data() + block * walls * 3;  // no walls: never written
    const std::size_t block_end = std::min(n, (block + 1) * kWallLoadBlock);
    for (std::size_t i = block * kWallLoadBlock; i < block_end; ++i) {
      Eigen::Vector3d f = p.mass[i] * g;
      Eigen::Vector3d tau = Eigen::Vector3d::Zero();
      double heat = 0.0;
      double conductance = 0.0;
      for (std::uint32_t k = list.row_begin[i]; k < list.row_begin[i + 1]; ++k) {
        f += Eigen::Vector3d(pair_forces.fx[k], pair_forces.fy[k], pair_forces.fz[k]);
        if constexpr (kFriction) {
          const double lever = p.radius[i] - pair_forces.half_overlap[k];
          tau += lever * Eigen::Vector3d(pair_forces.cx[k], pair_forces.cy[k], pair_forces.cz[k]);
          if (rolling) {
            tau += Eigen::Vector3d(pair_forces.roll_x[k], pair_forces.roll_y[k],
                                   pair_forces.roll_z[k]);
          }
        }
        if (thermal) {
          heat += pair_forces.heat[k];
          conductance += pair_forces.conductance[k];
        }
      }
      for (std::uint32_t c = list.column_begin[i]; c < list.column_begin[i + 1]; ++c) {
        const std::uint32_t k = list.column_pair[c];
        f -= Eigen::Vector3d(pair_forces.fx[k], pair_forces.fy[k], pair_forces.fz[k]);
        if constexpr (kFriction) {
          const double lever = p.radius[i] - pair_forces.half_overlap[k];
          tau += lever * Eigen::Vector3d(pair_forces.cx[k], pair_forces.cy[k], pair_forces.cz[k]);
          if (rolling) {
            tau -= Eigen::Vector3d(pair_forces.roll_x[k], pair_forces.roll_y[k],
                                   pair_forces.roll_z[k]);
          }
        }
        if (thermal) {
          heat -= pair_forces.heat[k];
          conductance += pair_forces.conductance[k];
        }
      }
      for (std::size_t w = 0; w < walls; ++w) {
        Eigen::Vector3d wall_f, wall_tau;
        const double overlap = boundary_contact<kFriction>(p, scene, w, i, wall_f, wall_tau);
        if (overlap <= 0.0) continue;
        block_load[w * 3 + 0] += wall_f.x();
        block_load[w * 3 + 1] += wall_f.y();
        block_load[w * 3 + 2] += wall_f.z();
        f += wall_f;
        tau += wall_tau;
        ++wall_contacts;
        max_overlap = std::max(max_overlap, overlap);
        max_fraction = std::max(max_fraction, overlap / p.radius[i]);
        if (thermal && w < scene.walls.size() && scene.walls[w].temperature > 0.0) {
          const PlaneWall& wall = scene.walls[w];
          const double h = spot_conductance(scene.pair(p.material[i], wall.material).conductivity,
                                            std::sqrt(p.radius[i]) * std::sqrt(overlap));
          heat += h * (wall.temperature - p.temperature[i]);
          conductance += h;
        }
      }
      if (thermal) {
        const double area = sphere_surface_area(p.radius[i]);
        const double t = p.temperature[i];
        const double emissivity = scene.emissivity[static_cast<std::size_t>(p.material[i])];
        heat += convection_heat(scene.convection_coefficient, area, scene.ambient_temperature, t) +
                radiation_heat(emissivity, area, scene.ambient_temperature, t);
        conductance += scene.convection_coefficient * area +
                       radiation_conductance(emissivity, area, scene.ambient_temperature, t);
        p.heat_rate[i] = heat;
        thermal_ratio =
            std::max(thermal_ratio, scene.time_step * conductance * p.inv_heat_capacity[i]);
      }
      p.fx[i] = f.x();
      p.fy[i] = f.y();
      p.fz[i] = f.z();
      if constexpr (kFriction) {
        p.tx[i] = tau.x();
        p.ty[i] = tau.y();
        p.tz[i] = tau.z();
      }
    }
  }
  ContactSummary summary;
  summary.wall_contacts = wall_contacts;
  summary.max_overlap = max_overlap;
  summary.max_overlap_fraction = max_fraction;
  summary.thermal_step_ratio = thermal_ratio;
  return summary;
}

}  // namespace bondem
