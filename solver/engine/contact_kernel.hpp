#pragma once
/// @file contact_kernel.hpp
/// Force kernels: evaluate the laws per candidate pair and per wall, then gather per particle.
///
/// Race-free and thread-count independent without atomics: pass 1 writes each pair's force into
/// its own slot; pass 2 sums, for each particle, its own row then its transposed row, in list
/// order. Every particle's sum therefore has one fixed order whatever the thread count.
///
/// The kernels loop, gather each contact's data, call the laws of solver/models/ and store what
/// they return; the formulas are the laws'. The normal-force law is a template argument (see
/// normal_law.hpp): the kernels are compiled once per law object, not per case option.

#include <omp.h>

#include <Eigen/Core>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <span>
#include <type_traits>
#include <variant>
#include <vector>

#include "geometry/boundary.hpp"
#include "geometry/triangle_mesh.hpp"
#include "solver/engine/boundary_candidates.hpp"
#include "solver/engine/exact_sum.hpp"
#include "solver/engine/neighbor_list.hpp"
#include "solver/engine/scene.hpp"
#include "solver/engine/staggered_vector.hpp"
#include "solver/engine/thread_split.hpp"
#include "solver/models/contact_laws.hpp"
#include "solver/models/contact_point.hpp"
#include "solver/models/heat_law.hpp"
#include "solver/models/normal_law.hpp"
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
/// the overlap, at lever pair_lever(r, delta) from either centre, so both torques are (lever
/// length) x (n x F_t) (contact_point.hpp). Pass 2 multiplies n x F_t by its own particle's lever.
/// Rolling torque (+ on i, - on j) takes 3 more only where the scene has rolling resistance.
struct PairForces {
  StaggeredVector<double> fx, fy, fz;
  StaggeredVector<std::uint8_t> bonded;  ///< 1 where the pair is on the adhesive branch
  StaggeredVector<double> cx, cy, cz;    ///< n x F_t: torque per metre of lever (friction)
  StaggeredVector<double> overlap;       ///< delta, which shortens both levers (friction)
  StaggeredVector<double> roll_x, roll_y, roll_z;  ///< rolling torque on i (rolling resistance)
  StaggeredVector<double> heat;                    ///< heat flow into i [W] (thermal runs)
  StaggeredVector<double> conductance;             ///< contact conductance H [W/K] (thermal runs)
  /// Where the pairs are kept as records (keeps_pair_records): each pair's (fx, fy, fz, delta,
  /// cx, cy, cz, 0), 64 B at records + 8 k, in place of the seven arrays above, which stay empty.
  /// Pass 2 then adds a pair's six sums with a vector or two a visit (gather_record_range).
  StaggeredVector<double> records;

  /// Whether the pairs are kept as records.
  bool in_records() const { return !records.empty(); }
  /// The pairs the slots are sized for.
  std::size_t pairs() const { return in_records() ? records.size() / 8 : fx.size(); }
  /// The force on i of pair @p k, from either layout.
  Eigen::Vector3d force(std::uint32_t k) const {
    if (in_records()) {
      const double* record = records.data() + 8 * std::size_t{k};
      return {record[0], record[1], record[2]};
    }
    return {fx[k], fy[k], fz[k]};
  }

  /// Slots for @p pairs pairs, with @p as_records one record each instead of the force and lever
  /// arrays. The bond flags keep their values (carry_pairs fills them first); the other slots are
  /// written by every pass 1, so a new size starts them at zero (in parallel).
  void resize(std::size_t pairs, bool torques, bool rolling, bool thermal,
              bool as_records = false) {
    const auto size = [](StaggeredVector<double>& slots, std::size_t count) {
      if (slots.size() != count) assign_zeros(slots, count);
    };
    const std::size_t arrays = as_records ? 0 : pairs;
    for (StaggeredVector<double>* f : {&fx, &fy, &fz}) size(*f, arrays);
    size(records, as_records ? 8 * pairs : 0);
    bonded.resize(pairs);
    for (StaggeredVector<double>* t : {&cx, &cy, &cz, &overlap}) size(*t, torques ? arrays : 0);
    for (StaggeredVector<double>* t : {&roll_x, &roll_y, &roll_z}) {
      size(*t, torques && rolling ? pairs : 0);
    }
    size(heat, thermal ? pairs : 0);
    size(conductance, thermal ? pairs : 0);
  }
};

/// What every candidate pair carries from step to step, indexed like the neighbor list: the
/// tangential spring elongation and, where some material pair needs them (contact_history), the
/// EPSD rolling spring and the JKR flag. It is carried across list rebuilds by particle ids (see
/// Stepper), so reordering never loses it.
struct PairHistory {
  StaggeredVector<double> sx, sy, sz;
  StaggeredVector<double> rx, ry, rz;    ///< EPSD rolling spring torque [N m]
  StaggeredVector<std::uint8_t> joined;  ///< 1 while a JKR contact holds the pair
  void resize(std::size_t pairs, bool springs, bool contact_history) {
    for (StaggeredVector<double>* s : {&sx, &sy, &sz}) assign_zeros(*s, springs ? pairs : 0);
    for (StaggeredVector<double>* r : {&rx, &ry, &rz}) {
      assign_zeros(*r, contact_history ? pairs : 0);
    }
    assign_zeros(joined, contact_history ? pairs : 0);
  }
};

// The named steps below are forced inline: they run once per pair or particle, and a call each
// (GCC otherwise keeps evaluate_pair, pair_friction and release_pair out of line) costs up to a
// third of the pair pass.

/// What pass 1 knows of a candidate pair before any law runs.
struct PairGeometry {
  double overlap;         ///< r_i + r_j - distance [m]
  double nx, ny, nz;      ///< unit n_ij, from i toward (the image of) j
  double r_star, m_star;  ///< effective radius and mass
};

/// The geometry of a block of pairs, measured in a short loop of its own (see
/// NeighborList::for_each_pair_block).
template <std::uint32_t kBlock>
struct PairGeometryBlock {
  double overlap[kBlock], nx[kBlock], ny[kBlock], nz[kBlock], r_star[kBlock], m_star[kBlock];

  [[gnu::always_inline]] void measure(std::uint32_t s, const Particles& p, const NeighborList& list,
                                      std::size_t i, std::size_t j, std::uint32_t k) {
    const Eigen::Vector3d d = list.separation(p, i, j, k);
    const double distance = std::sqrt(d.x() * d.x() + d.y() * d.y() + d.z() * d.z());
    const double inv_distance = 1.0 / distance;
    overlap[s] = pair_overlap(p.radius[i], p.radius[j], distance);
    nx[s] = d.x() * inv_distance;
    ny[s] = d.y() * inv_distance;
    nz[s] = d.z() * inv_distance;
    r_star[s] = effective_radius(p.radius[i], p.radius[j]);
    m_star[s] = effective_mass(p.mass[i], p.mass[j]);
  }
  [[gnu::always_inline]] PairGeometry at(std::uint32_t s) const {
    return {overlap[s], nx[s], ny[s], nz[s], r_star[s], m_star[s]};
  }
};

/// A candidate pair out of contact: no force, torque or heat, no bond, its springs released.
/// Returns 1 when it was bonded (a bond lost), else 0.
template <bool kFriction, bool kModels>
[[gnu::always_inline]] inline std::size_t release_pair(std::uint32_t k, bool thermal, bool rolling,
                                                       PairForces& out, PairHistory& history) {
  out.fx[k] = out.fy[k] = out.fz[k] = 0.0;
  const std::size_t lost = out.bonded[k];
  out.bonded[k] = 0;
  if (thermal) out.heat[k] = out.conductance[k] = 0.0;
  if constexpr (kFriction) {
    out.cx[k] = out.cy[k] = out.cz[k] = out.overlap[k] = 0.0;
    if (rolling) out.roll_x[k] = out.roll_y[k] = out.roll_z[k] = 0.0;
    history.sx[k] = history.sy[k] = history.sz[k] = 0.0;
  }
  if constexpr (kModels) {
    history.rx[k] = history.ry[k] = history.rz[k] = 0.0;
    history.joined[k] = 0;
  }
  return lost;
}

/// Friction and rolling resistance of contact k = (i, j) with normal part @p n: adds the
/// tangential force to slot k, stores its torque per lever, the overlap and the rolling torque,
/// and updates the springs in @p history.
template <bool kModels, class Law>
[[gnu::always_inline]] inline void pair_friction(const Particles& p, const Scene& scene,
                                                 const Law& law, const PairCoefficients& c,
                                                 const ContactNormal& n, const PairGeometry& g,
                                                 std::size_t i, std::size_t j, std::uint32_t k,
                                                 bool rolling, PairForces& out,
                                                 PairHistory& history) {
  const Eigen::Vector3d normal(g.nx, g.ny, g.nz);
  const Eigen::Vector3d lever_i = pair_lever(p.radius[i], g.overlap) * normal;
  const Eigen::Vector3d lever_j = -pair_lever(p.radius[j], g.overlap) * normal;
  const Eigen::Vector3d spin_i(p.wx[i], p.wy[i], p.wz[i]);
  const Eigen::Vector3d spin_j(p.wx[j], p.wy[j], p.wz[j]);
  const Eigen::Vector3d sliding = sliding_velocity(
      contact_velocity(Eigen::Vector3d(p.vx[i], p.vy[i], p.vz[i]), spin_i, lever_i,
                       Eigen::Vector3d(p.vx[j], p.vy[j], p.vz[j]), spin_j, lever_j),
      normal);
  Eigen::Vector3d slip(history.sx[k], history.sy[k], history.sz[k]);
  Eigen::Vector3d rolling_spring = Eigen::Vector3d::Zero();
  if constexpr (kModels) rolling_spring = {history.rx[k], history.ry[k], history.rz[k]};
  const ContactFriction t = contact_friction<kModels>(
      law, c, n, g.r_star, g.m_star, g.overlap, normal, sliding, spin_i - spin_j,
      [&] { return p.inverse_inertia(i) + p.inverse_inertia(j); }, rolling, slip, rolling_spring,
      scene.time_step);
  history.sx[k] = slip.x();
  history.sy[k] = slip.y();
  history.sz[k] = slip.z();
  if constexpr (kModels) {
    history.rx[k] = rolling_spring.x();
    history.ry[k] = rolling_spring.y();
    history.rz[k] = rolling_spring.z();
  }
  out.fx[k] += t.force.x();
  out.fy[k] += t.force.y();
  out.fz[k] += t.force.z();
  const Eigen::Vector3d per_lever = torque_per_lever(normal, t.force);
  out.cx[k] = per_lever.x();
  out.cy[k] = per_lever.y();
  out.cz[k] = per_lever.z();
  out.overlap[k] = g.overlap;
  if (!rolling) return;
  out.roll_x[k] = t.rolling_torque.x();
  out.roll_y[k] = t.rolling_torque.y();
  out.roll_z[k] = t.rolling_torque.z();
}

/// Contact k = (i, j) of pass 1 (in contact, or a JKR contact that still holds): the pair's
/// contact model, the contact's heat flow in thermal runs and, with kFriction, friction and
/// rolling; results stored in slot k.
template <bool kFriction, bool kModels, class Law>
[[gnu::always_inline]] inline ContactNormal evaluate_pair(
    const Particles& p, const Scene& scene, const Law& law, const PairCoefficients& coefficients,
    const PairGeometry& g, bool criterion_met, std::size_t i, std::size_t j, std::uint32_t k,
    bool thermal, bool rolling, PairForces& out, PairHistory& history) {
  const double overlap_rate =
      approach_rate(p.vx[j] - p.vx[i], p.vy[j] - p.vy[i], p.vz[j] - p.vz[i], g.nx, g.ny, g.nz);
  const auto pair = law.pair(coefficients, g.r_star, g.m_star);
  const ContactNormal f = contact_normal<kModels>(law, coefficients, pair, g.r_star, g.m_star,
                                                  g.overlap, overlap_rate, criterion_met);
  out.fx[k] = f.force * g.nx;
  out.fy[k] = f.force * g.ny;
  out.fz[k] = f.force * g.nz;
  out.bonded[k] = f.bonded ? 1 : 0;
  if constexpr (kModels) history.joined[k] = f.joined ? 1 : 0;
  if (thermal) {
    // A JKR contact conducts through its own contact radius, which stays open (a neck) even
    // where the overlap is negative; other contacts through the Hertz spot.
    const double spot =
        f.contact_radius > 0.0 ? f.contact_radius : spot_radius(g.r_star, g.overlap);
    const double h = spot_conductance(coefficients.conductivity, spot);
    out.conductance[k] = h;
    out.heat[k] = contact_heat_flow(h, p.temperature[i], p.temperature[j]);
  }
  if constexpr (kFriction) {
    pair_friction<kModels>(p, scene, law, coefficients, f, g, i, j, k, rolling, out, history);
  }
  return f;
}

/// The bonding criterion of eq. 25, chosen per material pair (PairCoefficients::criterion).
struct BondingCriterion {
  const Particles& particles;
  /// The pairs' bond flags of the previous evaluation.
  const StaggeredVector<std::uint8_t>& bonded;
  /// Caller's per-pair decision for criterion kPairFlag (by particle ids); null when no material
  /// pair has that criterion.
  const std::function<bool(std::int64_t, std::int64_t)>* pair_flag;

  /// Whether pair k = (i, j) with coefficients @p c may bond now.
  [[gnu::always_inline]] bool operator()(const PairCoefficients& c, std::size_t i, std::size_t j,
                                         std::uint32_t k) const {
    // Tests in order of how common the criteria are; a switch measured 9 instructions a contact.
    if (c.criterion == BondCriterion::kNever) return false;
    if (c.criterion == BondCriterion::kAlways) return true;
    if (c.criterion == BondCriterion::kTemperature) {
      return temperature_criterion(bonded[k] != 0, particles.temperature[i],
                                   particles.temperature[j], c.bond_temperature);
    }
    return (*pair_flag)(particles.id[i], particles.id[j]);
  }
};

/// Adds what pass 1 saw in one share of the rows, @p part, to @p sum.
inline void add_pair_summary(ContactSummary& sum, const ContactSummary& part) {
  sum.contacts += part.contacts;
  sum.bonds += part.bonds;
  sum.bonds_formed += part.bonds_formed;
  sum.bonds_broken += part.bonds_broken;
  sum.max_overlap = std::max(sum.max_overlap, part.max_overlap);
  sum.max_overlap_fraction = std::max(sum.max_overlap_fraction, part.max_overlap_fraction);
}

/// Particles (rows) per scheduling unit of pass 1, scalar and SIMD alike.
inline constexpr std::size_t kPairPassChunk = 64;

/// Pass 1: every candidate pair of @p list with the contact model of its material pair and the
/// normal-force law @p law (force on i stored; j gets minus).
/// @param criterion_met the bonding criterion; it reads out.bonded[k], which still holds the
/// pair's previous state.
/// In thermal runs each contact also gets its conductance and the heat flow into i.
/// With kFriction the pair also gets the tangential law (history in @p history) and rolling
/// resistance, and torques are stored; without it that code is compiled out. With kModels (some
/// material pair has cohesion or EPSD rolling: Particles::contact_history) the pairs also carry
/// the JKR flag and the EPSD spring in @p history; without it that code is compiled out.
/// @param counted per particle, 1 where the pairs in its row count in the summary's contacts,
/// bonds, formed and broken bonds (a decomposed run's rank counts the pairs whose first particle
/// it owns); null: all count. The largest overlaps take every pair.
/// @param split the threads' shares of the rows, kept across calls and balanced by their measured
/// times; null: equal shares.
template <bool kFriction, bool kModels, class Law>
ContactSummary compute_pair_forces(const Particles& p, const Scene& scene, const NeighborList& list,
                                   const Law& law, const BondingCriterion& criterion_met,
                                   PairForces& out, PairHistory& history,
                                   const std::uint8_t* counted = nullptr,
                                   ThreadSplit* split = nullptr) {
  const std::size_t n = p.size();
  const bool thermal = p.thermal();
  const bool rolling = kFriction && !out.roll_x.empty();
  constexpr std::uint32_t kBlock = 128;  // pairs per geometry block
  const std::size_t chunks = (n + kPairPassChunk - 1) / kPairPassChunk;
  const auto share = [&](int, std::size_t first_chunk, std::size_t end_chunk) {
    ContactSummary summary;
    for (std::size_t chunk = first_chunk; chunk < end_chunk; ++chunk) {
      PairGeometryBlock<kBlock> geometry;
      list.for_each_pair_block<kBlock>(
          chunk * kPairPassChunk, std::min(n, (chunk + 1) * kPairPassChunk),
          [&](std::uint32_t s, std::size_t i, std::size_t j, std::uint32_t k)
              __attribute__((always_inline)) { geometry.measure(s, p, list, i, j, k); },
          [&](std::uint32_t s, std::size_t i, std::size_t j, std::uint32_t k)
              __attribute__((always_inline)) {
                const PairGeometry g = geometry.at(s);
                if (!(g.overlap > 0.0) &&
                    !(kModels && history.joined[k] != 0 &&
                      g.overlap >
                          separation_overlap(scene.pair(p.material[i], p.material[j]), g.r_star))) {
                  const std::size_t released =
                      release_pair<kFriction, kModels>(k, thermal, rolling, out, history);
                  summary.bonds_broken += counted == nullptr || counted[i] != 0 ? released : 0;
                  return;
                }
                const bool was_bonded = out.bonded[k] != 0;
                const PairCoefficients& c = scene.pair(p.material[i], p.material[j]);
                const ContactNormal f = evaluate_pair<kFriction, kModels>(
                    p, scene, law, c, g, criterion_met(c, i, j, k), i, j, k, thermal, rolling, out,
                    history);
                summary.max_overlap = std::max(summary.max_overlap, g.overlap);
                summary.max_overlap_fraction = std::max(
                    summary.max_overlap_fraction, g.overlap / std::min(p.radius[i], p.radius[j]));
                if (counted != nullptr && counted[i] == 0) return;
                summary.bonds_formed += f.bonded && !was_bonded ? 1 : 0;
                summary.bonds_broken += !f.bonded && was_bonded ? 1 : 0;
                ++summary.contacts;
                summary.bonds += f.bonded ? 1 : 0;
              });
    }
    return summary;
  };
  ThreadSplit equal_shares;
  if (split == nullptr) split = &equal_shares;
  split->prepare(chunks, threads_in_use(n));
  return split->run(ContactSummary{}, share, add_pair_summary);
}

/// Releases the history of particle i against boundary slot @p slot: no contact there.
template <bool kFriction, bool kModels>
[[gnu::always_inline]] inline void release_surface(Particles& p, std::size_t slot, std::size_t i) {
  const std::size_t wall = i * static_cast<std::size_t>(p.walls) + slot;
  if constexpr (kFriction) {
    double* slip = &p.wall_slip[wall * 3];
    slip[0] = slip[1] = slip[2] = 0.0;
  }
  if constexpr (kModels) {
    double* held = &p.wall_contact[wall * Particles::kWallContactValues];
    held[0] = held[1] = held[2] = held[3] = 0.0;
  }
}

/// Contact of particle i with a surface of material @p material: the contact model of the pair
/// (particle material, @p material) with the surface as a partner of infinite radius and mass
/// (r* = r_i, m* = m_i, 1/I = 0) that never bonds, the same functions as a particle pair;
/// history in p.wall_slip and p.wall_contact slot @p slot.
/// @param gap centre-to-surface distance; @param normal unit, from the surface to the centre;
/// @param surface_velocity velocity of the surface material at the contact.
/// Returns the overlap (<= 0 and no JKR contact holding: zero force and torque, history
/// released).
template <bool kFriction, bool kModels, class Law>
double surface_contact(Particles& p, const Scene& scene, const Law& law, int material,
                       std::size_t slot, std::size_t i, double gap, const Eigen::Vector3d& normal,
                       const Eigen::Vector3d& surface_velocity, Eigen::Vector3d& force,
                       Eigen::Vector3d& torque) {
  const double overlap = surface_overlap(p.radius[i], gap);
  const std::size_t wall = i * static_cast<std::size_t>(p.walls) + slot;
  double* held = kModels ? &p.wall_contact[wall * Particles::kWallContactValues] : nullptr;
  torque.setZero();
  if (overlap <= 0.0 &&
      !(kModels && held[3] != 0.0 &&
        overlap > separation_overlap(scene.pair(p.material[i], material), p.radius[i]))) {
    force.setZero();
    release_surface<kFriction, kModels>(p, slot, i);
    return overlap;
  }
  const PairCoefficients& c = scene.pair(p.material[i], material);
  const auto pair = law.pair(c, p.radius[i], p.mass[i]);
  const Eigen::Vector3d velocity(p.vx[i], p.vy[i], p.vz[i]);
  const ContactNormal n =
      contact_normal<kModels>(law, c, pair, p.radius[i], p.mass[i], overlap,
                              surface_approach_rate(velocity, surface_velocity, normal), false);
  if constexpr (kModels) held[3] = n.joined ? 1.0 : 0.0;
  // n_ij points from the particle into the surface, i.e. along -normal.
  const Eigen::Vector3d n_ij = -normal;
  force = n.force * n_ij;
  if constexpr (kFriction) {
    double* slip = &p.wall_slip[wall * 3];
    const Eigen::Vector3d lever = surface_lever(p.radius[i], overlap) * n_ij;
    const Eigen::Vector3d spin(p.wx[i], p.wy[i], p.wz[i]);
    const Eigen::Vector3d sliding =
        sliding_velocity(surface_contact_velocity(velocity, spin, lever, surface_velocity), n_ij);
    Eigen::Vector3d spring(slip[0], slip[1], slip[2]);
    Eigen::Vector3d rolling_spring = Eigen::Vector3d::Zero();
    if constexpr (kModels) rolling_spring = {held[0], held[1], held[2]};
    const ContactFriction t = contact_friction<kModels>(
        law, c, n, p.radius[i], p.mass[i], overlap, n_ij, sliding, spin,
        [&] { return p.inverse_inertia(i); }, true, spring, rolling_spring, scene.time_step);
    slip[0] = spring.x();
    slip[1] = spring.y();
    slip[2] = spring.z();
    if constexpr (kModels) {
      held[0] = rolling_spring.x();
      held[1] = rolling_spring.y();
      held[2] = rolling_spring.z();
    }
    force += t.force;
    torque = moment(lever, t.force) + t.rolling_torque;
  }
  return overlap;
}

/// A mesh contact keeps its slot, and so its tangential and rolling history, when its normal
/// turned by less than 60 degrees since the last evaluation (cosine above this): rolling over a
/// tessellated floor or round a convex edge turns it by far less per step, while two faces of a
/// concave corner differ by 90 degrees or more.
inline constexpr double kSameMeshContactCosine = 0.5;

/// One contact a boundary made with particle i: what gather_boundaries adds up.
struct BoundaryContact {
  double overlap = 0.0;    ///< <= 0: no contact, though a holding JKR contact still pulls
  Eigen::Vector3d force;   ///< on the particle
  Eigen::Vector3d torque;  ///< on the particle, about its centre
  Eigen::Vector3d point;   ///< on the boundary surface, for the boundary's torque
};

/// The contact of particle i with analytic (non-mesh) boundary @p b in slot @p slot, or none
/// (overlap <= 0, zero force) when the sphere cannot reach it.
template <bool kFriction, bool kModels, class Law>
BoundaryContact analytic_boundary_contact(Particles& p, const Scene& scene, const Law& law,
                                          std::size_t b, const BoundaryFrame& frame,
                                          std::size_t i) {
  const Boundary& boundary = scene.boundaries[b];
  const std::size_t slot = static_cast<std::size_t>(scene.first_slot[b]);
  const Eigen::Vector3d centre(p.x[i], p.y[i], p.z[i]);
  BoundaryContact contact;
  if (const auto* plane = std::get_if<PlaneShape>(&boundary.shape)) {
    // The common boundary (substrates, container faces) on its own path: a plane does not turn,
    // and its distance costs less than a dispatch and a frame.
    const double gap = plane->nearest(centre - boundary.center).gap;
    contact.overlap = surface_contact<kFriction, kModels>(p, scene, law, boundary.material, slot, i,
                                                          gap, plane->normal, boundary.velocity,
                                                          contact.force, contact.torque);
    // Only a contact needs its point (for the plane's moment).
    if (contact.overlap > 0.0 || kModels) contact.point = centre - gap * plane->normal;
    return contact;
  }
  const Eigen::Vector3d w = frame.to_body(centre, boundary.center);
  const SurfacePoint local = std::visit(
      [&](const auto& shape) -> SurfacePoint {
        if constexpr (std::is_same_v<std::decay_t<decltype(shape)>, MeshShape>) {
          return {std::numeric_limits<double>::infinity(), Eigen::Vector3d::UnitZ()};
        } else {
          // A JKR contact reaches past touching by up to the scene's contact range.
          if (shape.surely_apart(w, p.radius[i] + scene.contact_range)) {
            return {std::numeric_limits<double>::infinity(), Eigen::Vector3d::UnitZ()};
          }
          return shape.nearest(w);
        }
      },
      boundary.shape);
  if (local.gap == std::numeric_limits<double>::infinity()) {
    // Most particles are far from most boundaries: no exact distance, no law, no history.
    contact.force.setZero();
    contact.torque.setZero();
    release_surface<kFriction, kModels>(p, slot, i);
    return contact;
  }
  const Eigen::Vector3d normal = frame.to_world(local.normal);
  contact.point = centre - local.gap * normal;
  contact.overlap = surface_contact<kFriction, kModels>(
      p, scene, law, boundary.material, slot, i, local.gap, normal,
      surface_velocity(boundary, contact.point), contact.force, contact.torque);
  return contact;
}

/// The contacts of particle i with mesh boundary @p b, each passed to @p add (a BoundaryContact),
/// in the double-contact rule's order. Each contact takes the slot whose last normal (boundary
/// frame) is nearest its own within kSameMeshContactCosine, else a free slot with fresh history;
/// slots left without a contact are released. The search runs among the particle's @p candidates;
/// a particle without any has no contact and holds no slot (boundary_candidates.hpp).
template <bool kFriction, bool kModels, class Law, class Add>
void mesh_boundary_contacts(Particles& p, const Scene& scene, const Law& law, std::size_t b,
                            const BoundaryFrame& frame, const BoundaryCandidates& candidates,
                            std::size_t i, MeshQueryBuffer& buffer, Add&& add) {
  const std::span<const BoxedTriangle> near(candidates.triangles.data() + candidates.start[i],
                                            candidates.start[i + 1] - candidates.start[i]);
  if (near.empty()) return;
  const Boundary& boundary = scene.boundaries[b];
  const MeshSurface& surface = *std::get<MeshShape>(boundary.shape).surface;
  const std::size_t first = static_cast<std::size_t>(scene.first_slot[b]);
  const int slots = scene.slot_count[b];
  double* normals = &p.wall_normal[(i * static_cast<std::size_t>(p.walls) + first) * 3];
  const Eigen::Vector3d centre(p.x[i], p.y[i], p.z[i]);
  const Eigen::Vector3d w = frame.to_body(centre, boundary.center);
  const double reach = p.radius[i] + scene.contact_range;
  // A slot without a normal holds no history (every contact stores its normal), so freeing it
  // again would only write zeros over zeros: most particles are far from most meshes.
  const auto release = [&](int s) {
    if (normals[3 * s] == 0.0 && normals[3 * s + 1] == 0.0 && normals[3 * s + 2] == 0.0) return;
    release_surface<kFriction, kModels>(p, first + static_cast<std::size_t>(s), i);
    normals[3 * s] = normals[3 * s + 1] = normals[3 * s + 2] = 0.0;
  };
  const std::span<const MeshContact> found =
      mesh_contacts_among(surface.mesh, near, w, reach, buffer);
  const int count = std::min(static_cast<int>(found.size()), slots);
  int slot_of[kMeshContactSlots];
  bool claimed[kMeshContactSlots] = {};
  // Carried contacts first: each takes the unclaimed slot whose normal is nearest its own.
  for (int k = 0; k < count; ++k) {
    slot_of[k] = -1;
    double best = kSameMeshContactCosine;
    for (int s = 0; s < slots; ++s) {
      const double cosine = normals[3 * s] * found[k].normal.x() +
                            normals[3 * s + 1] * found[k].normal.y() +
                            normals[3 * s + 2] * found[k].normal.z();
      if (!claimed[s] && cosine > best) {
        best = cosine;
        slot_of[k] = s;
      }
    }
    if (slot_of[k] >= 0) claimed[slot_of[k]] = true;
  }
  // New contacts take the first free slots, with fresh history.
  for (int k = 0; k < count; ++k) {
    if (slot_of[k] >= 0) continue;
    int s = 0;
    while (claimed[s]) ++s;
    release(s);
    slot_of[k] = s;
    claimed[s] = true;
  }
  for (int s = 0; s < slots; ++s) {
    if (!claimed[s]) release(s);
  }
  for (int k = 0; k < count; ++k) {
    const MeshContact& found_k = found[k];
    const int s = slot_of[k];
    BoundaryContact contact;
    const Eigen::Vector3d normal = frame.to_world(found_k.normal);
    contact.point = centre - found_k.gap * normal;
    contact.overlap = surface_contact<kFriction, kModels>(
        p, scene, law, boundary.material, first + static_cast<std::size_t>(s), i, found_k.gap,
        normal, surface_velocity(boundary, contact.point), contact.force, contact.torque);
    normals[3 * s] = found_k.normal.x();
    normals[3 * s + 1] = found_k.normal.y();
    normals[3 * s + 2] = found_k.normal.z();
    add(contact);
  }
}

/// Pass 2's pair sums of particles [@p first, @p end) from PairForces::records into their force
/// and torque arrays: the additions of gather_pair_range_into<true, false>, in its order, a
/// record's in lanes (pair_kernel_simd.cpp, dispatched to the target in use).
void gather_record_range(Particles& p, const NeighborList& list, const double* records,
                         const Eigen::Vector3d& gravity, std::size_t first, std::size_t end,
                         std::uint32_t mask = ~std::uint32_t{0});

/// Particles per block of gather_forces, the unit its threads share out.
inline constexpr std::size_t kWallLoadBlock = 64;

/// What one particle receives in pass 2, summed in one fixed order.
struct ParticleLoad {
  Eigen::Vector3d force;
  Eigen::Vector3d torque;
  double heat = 0.0;         ///< heat flow into the particle [W] (thermal runs)
  double conductance = 0.0;  ///< sum of its conductances [W/K] (thermal runs)
};

/// Which of a particle's pair sums a loop of pass 2 makes: all of them, or its forces alone or
/// its torques alone (two loops over the same particles, kSplitPairSumsParticles).
enum class PairSums { kAll, kForce, kTorque };

/// Adds particle i's pairs to @p load: its own row as stored, then the pairs in which it is the
/// second member with force, heat and rolling torque reversed (the lever torque keeps its sign).
/// The sums run in plain locals, one per component, in the same order as adding to @p load: a
/// ParticleLoad held by reference stayed in memory, and every add waited for the store of the one
/// before it (measured: the locals made the 20 800 peer lattice 1.10 times faster). With @p kSums
/// kForce or kTorque only those sums (each component's additions the same as with kAll).
template <bool kFriction, bool kRolling, bool kThermal, PairSums kSums = PairSums::kAll,
          class Slots = PairForces>
[[gnu::always_inline]] inline void gather_pairs(const Particles& p, const NeighborList& list,
                                                const Slots& pf, std::size_t i,
                                                ParticleLoad& load) {
  constexpr bool kForce = kSums != PairSums::kTorque;
  constexpr bool kTorque = kFriction && kSums != PairSums::kForce;
  double fx = load.force.x(), fy = load.force.y(), fz = load.force.z();
  double tx = load.torque.x(), ty = load.torque.y(), tz = load.torque.z();
  double heat = load.heat, conductance = load.conductance;
  const double radius = kTorque ? p.radius[i] : 0.0;
  const auto add_pair = [&](std::uint32_t k, double sign) __attribute__((always_inline)) {
    // sign is +1 or -1: a multiplication by it is exact, so the sums equal += and -=.
    if constexpr (kForce) {
      fx += sign * pf.fx[k];
      fy += sign * pf.fy[k];
      fz += sign * pf.fz[k];
    }
    if constexpr (kTorque) {
      const Eigen::Vector3d torque = lever_torque(pair_lever(radius, pf.overlap[k]),
                                                  Eigen::Vector3d(pf.cx[k], pf.cy[k], pf.cz[k]));
      tx += torque.x();
      ty += torque.y();
      tz += torque.z();
      if constexpr (kRolling) {
        tx += sign * pf.roll_x[k];
        ty += sign * pf.roll_y[k];
        tz += sign * pf.roll_z[k];
      }
    }
    if constexpr (kThermal) {
      heat += sign * pf.heat[k];
      conductance += pf.conductance[k];
    }
  };
  list.for_each_pair_of(
      i, [&](std::uint32_t k) __attribute__((always_inline)) { add_pair(k, 1.0); },
      [&](std::uint32_t k) __attribute__((always_inline)) { add_pair(k, -1.0); });
  load.force = Eigen::Vector3d(fx, fy, fz);
  load.torque = Eigen::Vector3d(tx, ty, tz);
  load.heat = heat;
  load.conductance = conductance;
}

/// Starts the loads of particles [@p first, @p end) with their weight (@p gravity) and adds
/// their pairs (gather_pairs), into @p loads by place in the range. One loop per kind of run:
/// the pair loop carries no test of rolling or heat.
template <bool kFriction, bool kRolling, bool kThermal>
void gather_pair_range(const Particles& p, const NeighborList& list, const PairForces& pf,
                       const Eigen::Vector3d& gravity, std::size_t first, std::size_t end,
                       ParticleLoad* loads) {
  for (std::size_t i = first; i < end; ++i) {
    ParticleLoad& load = loads[i - first];
    load = ParticleLoad{p.mass[i] * gravity, Eigen::Vector3d::Zero()};
    gather_pairs<kFriction, kRolling, kThermal>(p, list, pf, i, load);
  }
}

/// gather_pair_range straight into the particles' force (and, with kFriction, torque) arrays,
/// for a block no boundary can touch in a run without heat: the same sums, without the block's
/// loads in between (their stores and the copy out were a twentieth of the 20 800 peer lattice).
/// With @p kSums kForce or kTorque only those arrays (gather_pairs).
template <bool kFriction, bool kRolling, PairSums kSums = PairSums::kAll, class Slots = PairForces>
void gather_pair_range_into(Particles& p, const NeighborList& list, const Slots& pf,
                            const Eigen::Vector3d& gravity, std::size_t first, std::size_t end) {
  constexpr bool kForce = kSums != PairSums::kTorque;
  constexpr bool kTorque = kFriction && kSums != PairSums::kForce;
  // In locals: a store through the arrays could otherwise alias p's own members.
  double* __restrict force_x = p.fx.data();
  double* __restrict force_y = p.fy.data();
  double* __restrict force_z = p.fz.data();
  double* __restrict torque_x = p.tx.data();
  double* __restrict torque_y = p.ty.data();
  double* __restrict torque_z = p.tz.data();
  for (std::size_t i = first; i < end; ++i) {
    // The torque loop reads no mass.
    ParticleLoad load{
        kForce ? Eigen::Vector3d(p.mass[i] * gravity) : Eigen::Vector3d(Eigen::Vector3d::Zero()),
        Eigen::Vector3d::Zero()};
    gather_pairs<kFriction, kRolling, false, kSums, Slots>(p, list, pf, i, load);
    if constexpr (kForce) {
      force_x[i] = load.force.x();
      force_y[i] = load.force.y();
      force_z[i] = load.force.z();
    }
    if constexpr (kTorque) {
      torque_x[i] = load.torque.x();
      torque_y[i] = load.torque.y();
      torque_z[i] = load.torque.z();
    }
  }
}

/// Particles from which pass 2 (with friction, without heat) sums each run of
/// kSplitPairSumsBlocks blocks in two loops, forces then torques (gather_pair_range_into with
/// PairSums::kForce, then kTorque), instead of one. Out of cache every array a loop reads is a
/// stream from memory, and beyond about 16 at once this core's memory gives less: a test program
/// reading 1 GiB as 16 streams took 26-32 GB/s, as 24 to 48 streams 16-21 GB/s. One loop reads 16
/// streams here (seven slot arrays, the three indices, radius, mass, and writes six), each of the
/// two about ten. Measured, 50 steps of the 998 400 lattice, one thread, perf samples: pass 2 1
/// 806-1 864 -> 1 613-1 687. In cache the two loops cost more than one (the 20 800 lattice: 2 081
/// -> 2 144-2 181).
inline constexpr std::size_t kSplitPairSumsParticles = 32768;
/// The particle count from which pass 2 takes the two loops: kSplitPairSumsParticles unless moved
/// by set_split_pair_sums_from().
inline std::atomic<std::size_t> split_pair_sums_from{kSplitPairSumsParticles};
/// Sets the particle count from which pass 2 sums forces and torques in two loops and returns the
/// previous one. For tests and benchmarks: both ways give the same bytes.
inline std::size_t set_split_pair_sums_from(std::size_t particles) {
  return split_pair_sums_from.exchange(particles, std::memory_order_relaxed);
}
/// Blocks of a run of pass 2 without heat (its pair sums, then its boundaries, then
/// gather_forces's loaded): with the two loops, the second finds the run's indices (about 80 kB)
/// in the level-2 cache; a drift ahead finds its forces there. A run of one block cost 1 % at
/// 20 800 particles (the hand-over per block).
inline constexpr std::size_t kSplitPairSumsBlocks = 64;

/// Particles from which pass 2 prefetches the pair slots of its next block's transposed rows.
/// Those slots sit in other particles' rows, three streams per slot array on a lattice: out of
/// cache more streams than the hardware prefetchers follow (as pass 1's j particles,
/// kPrefetchParticles in pair_kernel_simd.cpp); in cache the prefetches would be overhead.
inline constexpr std::size_t kPrefetchSlotsParticles = 32768;

/// Prefetches the force slots (and, with kFriction, the lever terms) of the pairs in which
/// particles [@p first, @p end) are the second member.
template <bool kFriction>
void prefetch_column_slots(const NeighborList& list, const PairForces& pf, std::size_t first,
                           std::size_t end) {
  for (std::size_t i = first; i < end; ++i) {
    list.for_each_pair_of(
        i, [](std::uint32_t) {},
        [&](std::uint32_t k) {
          __builtin_prefetch(pf.fx.data() + k);
          __builtin_prefetch(pf.fy.data() + k);
          __builtin_prefetch(pf.fz.data() + k);
          if constexpr (kFriction) {
            __builtin_prefetch(pf.cx.data() + k);
            __builtin_prefetch(pf.cy.data() + k);
            __builtin_prefetch(pf.cz.data() + k);
            __builtin_prefetch(pf.overlap.data() + k);
          }
        });
  }
}

/// Whether some boundary may touch particles [@p first, @p end): a mesh always may, an
/// analytic boundary where one of them is in its reach (candidates.near, sorted).
inline bool boundary_within_reach(const Scene& scene,
                                  const std::vector<BoundaryCandidates>& candidates,
                                  std::size_t first, std::size_t end) {
  for (std::size_t b = 0; b < scene.boundaries.size(); ++b) {
    if (std::holds_alternative<MeshShape>(scene.boundaries[b].shape)) return true;
    const std::vector<std::uint32_t>& near = candidates[b].near;
    const auto at = std::lower_bound(near.begin(), near.end(), first);
    if (at != near.end() && *at < end) return true;
  }
  return false;
}

/// What the boundaries did to the particles of a block of pass 2.
struct BoundaryTally {
  std::size_t contacts = 0;
  double max_overlap = 0.0;
  double max_fraction = 0.0;
};

/// Values per boundary of the block loads of gather_forces: the force of the boundary on the
/// particles (3) and its moment about the boundary's reference point (3).
inline constexpr std::size_t kBoundaryLoadValues = 6;

/// Adds the contacts of boundary @p b with the particles [@p first, @p end) to their loads
/// @p loads (by place in the range; null: to their force and torque arrays, which hold their
/// sums so far, in runs without heat) and to the boundary loads (kBoundaryLoadValues per boundary)
/// of @p thread_load, or of @p uncounted_load for a particle that @p counted leaves to another
/// rank; boundaries held at a temperature also conduct heat. A mesh is searched for each
/// particle among its candidate triangles, an analytic boundary for the particles in its reach
/// (boundary_candidates.hpp): a particle without candidates has no contact with the boundary
/// and no history to release. Boundary by boundary, each particle still receives its boundaries in
/// case order.
template <bool kFriction, bool kModels, class Law>
void gather_boundary(Particles& p, const Scene& scene, const Law& law, std::size_t b,
                     const BoundaryFrame& frame, const BoundaryCandidates& candidates,
                     std::size_t first, std::size_t end, bool thermal, const std::uint8_t* counted,
                     MeshQueryBuffer& buffer, ExactSum* thread_load, ExactSum* uncounted_load,
                     ParticleLoad* loads, BoundaryTally& tally, BoundaryTally& uncounted) {
  const Boundary& boundary = scene.boundaries[b];
  const auto adder = [&](std::size_t i) {
    return [&, i](const BoundaryContact& contact) {
      // A JKR contact held apart still pulls; it conducts no heat and counts as no contact.
      if (contact.overlap <= 0.0 && !kModels) return;
      const bool counts = counted == nullptr || counted[i] != 0;
      ExactSum* boundary_load = (counts ? thread_load : uncounted_load) + b * kBoundaryLoadValues;
      BoundaryTally& kept = counts ? tally : uncounted;
      const Eigen::Vector3d moment = (contact.point - boundary.center).cross(contact.force);
      for (int axis = 0; axis < 3; ++axis) {
        boundary_load[axis].add(contact.force[axis]);
        boundary_load[3 + axis].add(moment[axis]);
      }
      if (loads == nullptr) {  // the pair sums are stored: the same adds, in the same order
        p.fx[i] += contact.force.x();
        p.fy[i] += contact.force.y();
        p.fz[i] += contact.force.z();
        if constexpr (kFriction) {
          p.tx[i] += contact.torque.x();
          p.ty[i] += contact.torque.y();
          p.tz[i] += contact.torque.z();
        }
      } else {
        loads[i - first].force += contact.force;
        loads[i - first].torque += contact.torque;
      }
      if (contact.overlap <= 0.0) return;
      ++kept.contacts;
      kept.max_overlap = std::max(kept.max_overlap, contact.overlap);
      kept.max_fraction = std::max(kept.max_fraction, contact.overlap / p.radius[i]);
      if (thermal && boundary.temperature > 0.0) {
        ParticleLoad& load = loads[i - first];  // thermal runs stage their loads
        const double h = spot_conductance(scene.pair(p.material[i], boundary.material).conductivity,
                                          spot_radius(p.radius[i], contact.overlap));
        load.heat += contact_heat_flow(h, p.temperature[i], boundary.temperature);
        load.conductance += h;
      }
    };
  };
  if (std::holds_alternative<MeshShape>(boundary.shape)) {
    for (std::size_t i = first; i < end; ++i) {
      mesh_boundary_contacts<kFriction, kModels>(p, scene, law, b, frame, candidates, i, buffer,
                                                 adder(i));
    }
    return;
  }
  const std::vector<std::uint32_t>& near = candidates.near;
  for (auto at = std::lower_bound(near.begin(), near.end(), first); at != near.end() && *at < end;
       ++at) {
    const std::size_t i = *at;
    const BoundaryContact contact =
        analytic_boundary_contact<kFriction, kModels>(p, scene, law, b, frame, i);
    if (contact.overlap > 0.0 || (kModels && contact.force != Eigen::Vector3d::Zero())) {
      adder(i)(contact);
    }
  }
}

/// Adds particle i's convection and radiation to the surroundings to @p load (thermal runs).
[[gnu::always_inline]] inline void exchange_with_surroundings(const Particles& p,
                                                              const Scene& scene, std::size_t i,
                                                              ParticleLoad& load) {
  const SurroundingsExchange exchange = surroundings_exchange(
      scene.convection_coefficient, scene.emissivity[static_cast<std::size_t>(p.material[i])],
      sphere_surface_area(p.radius[i]), scene.ambient_temperature, p.temperature[i]);
  load.heat += exchange.heat;
  load.conductance += exchange.conductance;
}

/// One force-slot array of a FusedRing: pair k's value at [k mod (mask + 1)].
struct RingSlot {
  const double* values;
  std::uint32_t mask;
  double operator[](std::uint32_t k) const { return values[k & mask]; }
};

/// The slots of a FusedRing as pass 2 reads them (gather_pairs), in place of PairForces.
struct RingSlots {
  RingSlot fx, fy, fz, cx, cy, cz, overlap;
};

/// Where the fused pass keeps the pairs that are read after its ring has moved past them (the
/// pairs of the particles that wait for the end of pass 1): a record each, (fx, fy, fz, delta,
/// cx, cy, cz, 0), for the pairs marked in @c bits (numbered by their rank among them) and for
/// the pairs of two ranges of pair indices (numbered from their range's base).
struct KeptPairs {
  const std::uint64_t* bits = nullptr;  ///< a bit per pair: kept whatever the ranges
  const std::uint32_t* rank = nullptr;  ///< per 64 pairs, the marked pairs before them
  /// Ranges [from, to) of pairs kept too, and the record index of each range's first pair:
  /// windows[3 w], windows[3 w + 1], windows[3 w + 2] for w < window_count.
  const std::uint32_t* windows = nullptr;
  int window_count = 0;
  double* records = nullptr;

  /// The range holding pair @p k, or -1.
  int in_window(std::uint32_t k) const {
    for (int w = 0; w < window_count; ++w) {
      if (k >= windows[3 * w] && k < windows[3 * w + 1]) return w;
    }
    return -1;
  }
  /// Whether pair @p k is kept.
  bool kept(std::uint32_t k) const {
    return in_window(k) >= 0 || ((bits[k >> 6] >> (k & 63)) & 1) != 0;
  }
  /// Pair @p k's record (a kept pair's).
  double* record(std::uint32_t k) const {
    const int w = in_window(k);
    if (w >= 0) return records + 8 * std::size_t{windows[3 * w + 2] + (k - windows[3 * w])};
    const std::uint64_t below = bits[k >> 6] & ((std::uint64_t{1} << (k & 63)) - 1);
    const auto before = static_cast<std::uint32_t>(__builtin_popcountll(below));
    return records + 8 * std::size_t{rank[k >> 6] + before};
  }
};

/// One value of the kept pairs' records as pass 2 reads it (gather_pairs), @c field of each.
struct KeptField {
  const KeptPairs* kept;
  int field;
  double operator[](std::uint32_t k) const { return kept->record(k)[field]; }
};

/// The kept pairs as pass 2 reads them, in place of PairForces.
struct KeptSlots {
  KeptField fx, fy, fz, cx, cy, cz, overlap;
  explicit KeptSlots(const KeptPairs& kept)
      : fx{&kept, 0},
        fy{&kept, 1},
        fz{&kept, 2},
        cx{&kept, 4},
        cy{&kept, 5},
        cz{&kept, 6},
        overlap{&kept, 3} {}
};

/// The records of a FusedRing: pair k's at records + 8 (k & mask) (gather_record_range).
struct RingRecords {
  const double* records;
  std::uint32_t mask;
};

/// Pass 2 of particles [@p first, @p end) in a run without heat or rolling slots, straight into
/// their force and torque arrays: weight and pair sums from @p slots (PairForces or RingSlots),
/// forces then torques (PairSums), then every boundary's contacts, into @p share_load as in
/// gather_forces: the additions of gather_forces's run without heat, in its order. For the fused
/// pass (Stepper), which sums each run as soon as pass 1 has done the rows its pairs sit in.
template <bool kFriction, bool kModels, class Law, class Slots>
ContactSummary gather_range(Particles& p, const Scene& scene, const NeighborList& list,
                            const std::vector<BoundaryCandidates>& candidates,
                            const std::vector<BoundaryFrame>& frames, const Law& law,
                            const Slots& slots, ExactSum* share_load, std::size_t first,
                            std::size_t end) {
  if constexpr (std::is_same_v<Slots, RingRecords>) {
    gather_record_range(p, list, slots.records, scene.gravity, first, end, slots.mask);
  } else {
    gather_pair_range_into<kFriction, false, PairSums::kForce>(p, list, slots, scene.gravity, first,
                                                               end);
    if constexpr (kFriction) {
      gather_pair_range_into<kFriction, false, PairSums::kTorque>(p, list, slots, scene.gravity,
                                                                  first, end);
    }
  }
  ContactSummary summary;
  thread_local MeshQueryBuffer buffer;  // reused: mesh queries allocate only while it grows
  for (std::size_t block = first; block < end;) {
    const std::size_t block_end = std::min(end, (block / kWallLoadBlock + 1) * kWallLoadBlock);
    if (boundary_within_reach(scene, candidates, block, block_end)) {
      BoundaryTally tally;
      BoundaryTally uncounted;
      for (std::size_t b = 0; b < scene.boundaries.size(); ++b) {
        gather_boundary<kFriction, kModels>(p, scene, law, b, frames[b], candidates[b], block,
                                            block_end, false, nullptr, buffer, share_load, nullptr,
                                            nullptr, tally, uncounted);
      }
      summary.wall_contacts += tally.contacts;
      summary.max_overlap = std::max(summary.max_overlap, tally.max_overlap);
      summary.max_overlap_fraction = std::max(summary.max_overlap_fraction, tally.max_fraction);
    }
    block = block_end;
  }
  return summary;
}

/// What gather_forces calls with (share, first, end) once particles [first, end) are loaded.
using LoadedRange = std::function<void(int, std::size_t, std::size_t)>;

/// Pass 2: total force (and, with kFriction, torque) per particle = gravity + own pairs -
/// transposed pairs + boundaries. The force and moment of each boundary on the particles are
/// summed exactly per share of @p split into @p wall_loads (kBoundaryLoadValues per share and
/// boundary): the caller merges the shares' sums, which are the same bytes for any thread count,
/// any split and any order of the particles. @p split: the threads' shares of the particles'
/// blocks, kept across calls and balanced by their measured times. In thermal runs the same order
/// sums the heat flows into p.heat_rate: contacts, boundaries held at a temperature, convection and
/// radiation (the laser is added by the caller). @p frames: every boundary's frame_of at its
/// current pose. kModels as in compute_pair_forces. With @p counted (as in compute_pair_forces),
/// only the particles marked 1 add to the boundary loads and the boundary contacts; the largest
/// overlaps take every particle. With @p loaded (runs without heat only), each thread calls
/// (*loaded)(share, first, end), share as in ThreadSplit::run, as soon as particles [first, end)
/// (a run of kSplitPairSumsBlocks blocks) hold their whole force and torque, while those are still
/// in its caches (Stepper::drift_ahead).
template <bool kFriction, bool kModels, class Law>
ContactSummary gather_forces(Particles& p, const Scene& scene, const NeighborList& list,
                             const std::vector<BoundaryCandidates>& candidates,
                             const std::vector<BoundaryFrame>& frames, const Law& law,
                             const PairForces& pair_forces, std::vector<ExactSum>& wall_loads,
                             ThreadSplit& split, const std::uint8_t* counted = nullptr,
                             const LoadedRange* loaded = nullptr) {
  const std::size_t n = p.size();
  const std::size_t boundaries = scene.boundaries.size();
  const std::size_t blocks = (n + kWallLoadBlock - 1) / kWallLoadBlock;
  split.prepare(blocks, threads_in_use(n));
  wall_loads.assign(static_cast<std::size_t>(split.threads()) * boundaries * kBoundaryLoadValues,
                    ExactSum{});
  const Eigen::Vector3d g = scene.gravity;
  const bool thermal = p.thermal();
  const bool rolling = kFriction && !pair_forces.roll_x.empty();
  const bool prefetch = n >= kPrefetchSlotsParticles;
  const bool split_sums = kFriction && n >= split_pair_sums_from.load(std::memory_order_relaxed);
  const auto share = [&](int share_index, std::size_t first_block, std::size_t end_block) {
    ContactSummary summary;
    // Without boundaries never written.
    ExactSum* share_load = wall_loads.data() +
                           static_cast<std::size_t>(share_index) * boundaries * kBoundaryLoadValues;
    thread_local MeshQueryBuffer buffer;  // reused: mesh queries allocate only while it grows
    thread_local std::vector<ExactSum> uncounted_load;
    if (counted != nullptr) uncounted_load.resize(boundaries * kBoundaryLoadValues);
    // Every boundary's contacts with particles [first, end), into staged or, if null, the arrays.
    const auto add_boundaries = [&](std::size_t first, std::size_t end, ParticleLoad* staged,
                                    BoundaryTally& tally, BoundaryTally& uncounted) {
      for (std::size_t b = 0; b < boundaries; ++b) {
        gather_boundary<kFriction, kModels>(p, scene, law, b, frames[b], candidates[b], first, end,
                                            thermal, counted, buffer, share_load,
                                            uncounted_load.data(), staged, tally, uncounted);
      }
    };
    const auto add_tallies = [&](const BoundaryTally& tally, const BoundaryTally& uncounted) {
      summary.wall_contacts += tally.contacts;
      summary.max_overlap =
          std::max({summary.max_overlap, tally.max_overlap, uncounted.max_overlap});
      summary.max_overlap_fraction =
          std::max({summary.max_overlap_fraction, tally.max_fraction, uncounted.max_fraction});
    };
    if (!thermal) {
      // The pair sums straight into the force arrays, then each boundary's contacts added to
      // them: the additions of the staged loads below in the same order, without the loads'
      // stores and copy (the blocks the floor reaches on the 20 800 peer lattice). Run by run of
      // blocks: its pair sums (with split_sums a loop for its forces, then one for its torques,
      // kSplitPairSumsParticles; else block by block), then its blocks' boundaries, then loaded.
      for (std::size_t run = first_block; run < end_block; run += kSplitPairSumsBlocks) {
        const std::size_t run_end = std::min(end_block, run + kSplitPairSumsBlocks);
        const std::size_t first = run * kWallLoadBlock;
        const std::size_t end = std::min(n, run_end * kWallLoadBlock);
        if (pair_forces.in_records()) {
          gather_record_range(p, list, pair_forces.records.data(), g, first, end);
        } else if (split_sums) {
          gather_pair_range_into<kFriction, false, PairSums::kForce>(p, list, pair_forces, g, first,
                                                                     end);
          if (rolling) {
            gather_pair_range_into<kFriction, true, PairSums::kTorque>(p, list, pair_forces, g,
                                                                       first, end);
          } else {
            gather_pair_range_into<kFriction, false, PairSums::kTorque>(p, list, pair_forces, g,
                                                                        first, end);
          }
        } else {
          for (std::size_t block = run; block < run_end; ++block) {
            const std::size_t block_begin = block * kWallLoadBlock;
            const std::size_t block_end = std::min(n, block_begin + kWallLoadBlock);
            if (prefetch && block + 1 < end_block) {
              prefetch_column_slots<kFriction>(list, pair_forces, block_end,
                                               std::min(n, block_end + kWallLoadBlock));
            }
            if (rolling) {
              gather_pair_range_into<kFriction, true>(p, list, pair_forces, g, block_begin,
                                                      block_end);
            } else {
              gather_pair_range_into<kFriction, false>(p, list, pair_forces, g, block_begin,
                                                       block_end);
            }
          }
        }
        for (std::size_t block = run; block < run_end; ++block) {
          const std::size_t block_begin = block * kWallLoadBlock;
          const std::size_t block_end = std::min(n, block_begin + kWallLoadBlock);
          if (!boundary_within_reach(scene, candidates, block_begin, block_end)) continue;
          BoundaryTally tally;
          BoundaryTally uncounted;  // of particles another rank counts: only its maxima are kept
          add_boundaries(block_begin, block_end, nullptr, tally, uncounted);
          add_tallies(tally, uncounted);
        }
        if (loaded != nullptr) (*loaded)(share_index, first, end);
      }
      return summary;
    }
    for (std::size_t block = first_block; block < end_block; ++block) {
      BoundaryTally tally;
      BoundaryTally uncounted;  // of particles another rank counts: only its maxima are kept
      const std::size_t block_begin = block * kWallLoadBlock;
      const std::size_t block_end = std::min(n, block_begin + kWallLoadBlock);
      if (prefetch && block + 1 < end_block) {
        prefetch_column_slots<kFriction>(list, pair_forces, block_end,
                                         std::min(n, block_end + kWallLoadBlock));
      }
      // A thermal run stages each block's loads: heat and conductance are summed beside the force
      // and torque, and the surroundings' exchange comes last.
      ParticleLoad loads[kWallLoadBlock];
      if (rolling) {
        gather_pair_range<kFriction, true, true>(p, list, pair_forces, g, block_begin, block_end,
                                                 loads);
      } else {
        gather_pair_range<kFriction, false, true>(p, list, pair_forces, g, block_begin, block_end,
                                                  loads);
      }
      add_boundaries(block_begin, block_end, loads, tally, uncounted);
      // In locals: a store through the arrays could otherwise alias p's own members.
      double* __restrict force_x = p.fx.data();
      double* __restrict force_y = p.fy.data();
      double* __restrict force_z = p.fz.data();
      double* __restrict torque_x = p.tx.data();
      double* __restrict torque_y = p.ty.data();
      double* __restrict torque_z = p.tz.data();
      for (std::size_t i = block_begin; i < block_end; ++i) {
        ParticleLoad& load = loads[i - block_begin];
        exchange_with_surroundings(p, scene, i, load);
        p.heat_rate[i] = load.heat;
        summary.thermal_step_ratio =
            std::max(summary.thermal_step_ratio,
                     thermal_step_ratio(scene.time_step, load.conductance, p.inv_heat_capacity[i]));
        force_x[i] = load.force.x();
        force_y[i] = load.force.y();
        force_z[i] = load.force.z();
        if constexpr (kFriction) {
          torque_x[i] = load.torque.x();
          torque_y[i] = load.torque.y();
          torque_z[i] = load.torque.z();
        }
      }
      add_tallies(tally, uncounted);
    }
    return summary;
  };
  return split.run(ContactSummary{}, share, [](ContactSummary& sum, const ContactSummary& part) {
    sum.wall_contacts += part.wall_contacts;
    sum.max_overlap = std::max(sum.max_overlap, part.max_overlap);
    sum.max_overlap_fraction = std::max(sum.max_overlap_fraction, part.max_overlap_fraction);
    sum.thermal_step_ratio = std::max(sum.thermal_step_ratio, part.thermal_step_ratio);
  });
}

}  // namespace bondem
