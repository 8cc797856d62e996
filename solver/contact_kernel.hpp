#pragma once
/// @file contact_kernel.hpp
/// Force kernels: evaluate the laws per candidate pair and per wall, then gather per particle.
///
/// Race-free and thread-count independent without atomics: pass 1 writes each pair's force into
/// its own slot; pass 2 sums, for each particle, its own row then its transposed row, in list
/// order. Every particle's sum therefore has one fixed order whatever the thread count.

#include <algorithm>
#include <cmath>
#include <vector>

#include "geometry/walls.hpp"
#include "solver/bond_law.hpp"
#include "solver/neighbor_list.hpp"
#include "solver/pair.hpp"
#include "solver/scene.hpp"

namespace bondem {

/// What a force evaluation saw.
struct ContactSummary {
  std::size_t contacts = 0;           ///< particle pairs with positive overlap
  std::size_t bonds = 0;              ///< contacts on the adhesive branch of eq. 25
  std::size_t wall_contacts = 0;      ///< particle-wall contacts
  double max_overlap = 0.0;           ///< largest overlap of any contact [m]
  double max_overlap_fraction = 0.0;  ///< largest overlap / radius of the smaller body
};

/// Per-pair forces on the first particle of each pair, one slot per neighbor-list entry.
struct PairForces {
  std::vector<double> fx, fy, fz;
  std::vector<std::uint8_t> bonded;  ///< 1 where the pair is on the adhesive branch
  void resize(std::size_t pairs) {
    fx.resize(pairs);
    fy.resize(pairs);
    fz.resize(pairs);
    bonded.resize(pairs);
  }
};

/// Pass 1: the bond law for every candidate pair of @p list (force on i stored; j gets minus).
/// @param criterion_met callable (i, j) -> bool, the bonding criterion of the pair.
template <class Adhesion, class Criterion>
ContactSummary compute_pair_forces(const Particles& p, const Scene& scene, const NeighborList& list,
                                   Adhesion adhesion, Criterion criterion_met, PairForces& out) {
  const std::size_t n = p.size();
  std::size_t contacts = 0;
  std::size_t bonds = 0;
  double max_overlap = 0.0;
  double max_fraction = 0.0;
#pragma omp parallel for schedule(static) if (n >= kMinParallelParticles) \
    reduction(+ : contacts, bonds) reduction(max : max_overlap, max_fraction)
  for (std::size_t i = 0; i < n; ++i) {
    for (std::uint32_t k = list.row_begin[i]; k < list.row_begin[i + 1]; ++k) {
      const std::size_t j = list.second[k];
      const Eigen::Vector3d& shift = list.shifts[list.image[k]];
      const double dx = p.x[j] - p.x[i] + shift.x();
      const double dy = p.y[j] - p.y[i] + shift.y();
      const double dz = p.z[j] - p.z[i] + shift.z();
      const double distance_sq = dx * dx + dy * dy + dz * dz;
      const double reach = p.radius[i] + p.radius[j];
      if (distance_sq >= reach * reach) {
        out.fx[k] = out.fy[k] = out.fz[k] = 0.0;
        out.bonded[k] = 0;
        continue;
      }
      const double distance = std::sqrt(distance_sq);
      const double overlap = reach - distance;
      const double inv_distance = 1.0 / distance;
      const double nx = dx * inv_distance;
      const double ny = dy * inv_distance;
      const double nz = dz * inv_distance;
      // delta-dot = -(v_j - v_i) . n_ij: positive while approaching.
      const double overlap_rate =
          -((p.vx[j] - p.vx[i]) * nx + (p.vy[j] - p.vy[i]) * ny + (p.vz[j] - p.vz[i]) * nz);
      const BondPair law = make_bond_pair(scene.pair(p.material[i], p.material[j]),
                                          effective_radius(p.radius[i], p.radius[j]),
                                          effective_mass(p.mass[i], p.mass[j]));
      const NormalForce f = normal_force(law, adhesion, overlap, overlap_rate, criterion_met(i, j));
      out.fx[k] = f.force * nx;
      out.fy[k] = f.force * ny;
      out.fz[k] = f.force * nz;
      out.bonded[k] = f.bonded ? 1 : 0;
      ++contacts;
      bonds += f.bonded ? 1 : 0;
      max_overlap = std::max(max_overlap, overlap);
      max_fraction = std::max(max_fraction, overlap / std::min(p.radius[i], p.radius[j]));
    }
  }
  return {contacts, bonds, 0, max_overlap, max_fraction};
}

/// Damped Hertz force of @p wall on particle i (zero when apart); returns the overlap.
inline double wall_force(const Particles& p, const Scene& scene, const PlaneWall& wall,
                         std::size_t i, Eigen::Vector3d& force) {
  const double overlap = p.radius[i] - distance_to(wall, p.x[i], p.y[i], p.z[i]);
  if (overlap <= 0.0) {
    force.setZero();
    return overlap;
  }
  // The wall is a sphere of infinite radius and mass: r* = r_i, m* = m_i.
  const PairCoefficients& c = scene.pair(p.material[i], wall.material);
  const BondPair law{hertz_stiffness(c.effective_modulus, p.radius[i]),
                     p.mass[i],
                     0.0,
                     0.0,
                     0.0,
                     c.contact_damping,
                     0.0};
  const double overlap_rate =
      -(p.vx[i] * wall.normal.x() + p.vy[i] * wall.normal.y() + p.vz[i] * wall.normal.z());
  // n_ij points from the particle into the wall, i.e. along -normal.
  const double f_n = hertz_contact_force(law, overlap, overlap_rate);
  force = -f_n * wall.normal;
  return overlap;
}

/// Pass 2: total force per particle = gravity + own pairs - transposed pairs + walls.
inline ContactSummary gather_forces(Particles& p, const Scene& scene, const NeighborList& list,
                                    const PairForces& pair_forces) {
  const std::size_t n = p.size();
  const Eigen::Vector3d g = scene.gravity;
  std::size_t wall_contacts = 0;
  double max_overlap = 0.0;
  double max_fraction = 0.0;
#pragma omp parallel for schedule(static) if (n >= kMinParallelParticles) \
    reduction(+ : wall_contacts) reduction(max : max_overlap, max_fraction)
  for (std::size_t i = 0; i < n; ++i) {
    double fx = p.mass[i] * g.x();
    double fy = p.mass[i] * g.y();
    double fz = p.mass[i] * g.z();
    for (std::uint32_t k = list.row_begin[i]; k < list.row_begin[i + 1]; ++k) {
      fx += pair_forces.fx[k];
      fy += pair_forces.fy[k];
      fz += pair_forces.fz[k];
    }
    for (std::uint32_t c = list.column_begin[i]; c < list.column_begin[i + 1]; ++c) {
      const std::uint32_t k = list.column_pair[c];
      fx -= pair_forces.fx[k];
      fy -= pair_forces.fy[k];
      fz -= pair_forces.fz[k];
    }
    for (const PlaneWall& wall : scene.walls) {
      Eigen::Vector3d f;
      const double overlap = wall_force(p, scene, wall, i, f);
      if (overlap <= 0.0) continue;
      fx += f.x();
      fy += f.y();
      fz += f.z();
      ++wall_contacts;
      max_overlap = std::max(max_overlap, overlap);
      max_fraction = std::max(max_fraction, overlap / p.radius[i]);
    }
    p.fx[i] = fx;
    p.fy[i] = fy;
    p.fz[i] = fz;
  }
  return {0, 0, wall_contacts, max_overlap, max_fraction};
}

}  // namespace bondem
