#pragma once
/// @file contact_kernel.hpp
/// The particle-particle force kernel: loops over candidate pairs and applies the bond law.

#include <algorithm>
#include <cmath>
#include <vector>

#include "solver/bond_law.hpp"
#include "solver/neighbors.hpp"
#include "solver/pair.hpp"
#include "solver/scene.hpp"

namespace bondem {

/// What the kernel saw in one evaluation.
struct ContactSummary {
  std::size_t contacts = 0;  ///< pairs with positive overlap
  std::size_t bonds = 0;     ///< contacts on the adhesive branch of eq. 25
  double max_overlap = 0.0;  ///< largest overlap [m]
};

/// Add the contact force of every overlapping pair to p.f{x,y,z} (i gets +f, j gets -f).
/// Pairs are visited in list order, so the sums do not depend on anything but the list.
/// @param criterion_met callable (i, j) -> bool, the bonding criterion of the pair.
template <class Adhesion, class Criterion>
ContactSummary accumulate_contact_forces(Particles& p, const Scene& scene,
                                         const std::vector<ContactPair>& pairs, Adhesion adhesion,
                                         Criterion criterion_met) {
  ContactSummary summary;
  for (const ContactPair& pair : pairs) {
    const std::size_t i = pair.i;
    const std::size_t j = pair.j;
    const double dx = p.x[j] - p.x[i];
    const double dy = p.y[j] - p.y[i];
    const double dz = p.z[j] - p.z[i];
    const double distance_sq = dx * dx + dy * dy + dz * dz;
    const double reach = p.radius[i] + p.radius[j];
    if (distance_sq >= reach * reach) continue;
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
    p.fx[i] += f.force * nx;
    p.fy[i] += f.force * ny;
    p.fz[i] += f.force * nz;
    p.fx[j] -= f.force * nx;
    p.fy[j] -= f.force * ny;
    p.fz[j] -= f.force * nz;
    ++summary.contacts;
    summary.bonds += f.bonded ? 1 : 0;
    summary.max_overlap = std::max(summary.max_overlap, overlap);
  }
  return summary;
}

}  // namespace bondem
