#include "solver/experiments/collision.hpp"

#include <cmath>
#include <stdexcept>

#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"
#include "solver/models/contact_laws.hpp"

namespace bondem {

CollisionResult collide(const Case& description, double velocity,
                        const std::function<void(const CollisionSample&)>& trace) {
  if (description.particles.size() != 2) {
    throw std::invalid_argument("collide needs a case with exactly two particles, found " +
                                std::to_string(description.particles.size()));
  }
  if (!(velocity > 0.0) || !std::isfinite(velocity)) {
    throw std::invalid_argument("collide needs a positive, finite impact velocity");
  }
  Case setup = description;
  setup.gravity.setZero();
  ParticleSpec& first = setup.particles.edit(0);
  ParticleSpec& second = setup.particles.edit(1);
  Eigen::Vector3d normal = second.position - first.position;
  normal = normal.norm() > 0.0 ? normal.normalized() : Eigen::Vector3d::UnitX();
  second.position = first.position + (first.radius + second.radius) * normal;
  // Zero total momentum: each particle takes the share of V set by the other's mass.
  const double m_first = sphere_mass(first.radius, setup.materials[first.material].density);
  const double m_second = sphere_mass(second.radius, setup.materials[second.material].density);
  const double total_mass = m_first + m_second;
  first.velocity = velocity * m_second / total_mass * normal;
  second.velocity = -velocity * m_first / total_mass * normal;

  Scene scene = build_scene(setup);
  Stepper stepper(scene);
  const Particles& p = scene.particles;
  const double reach = first.radius + second.radius;
  const auto steps = static_cast<std::int64_t>(std::llround(setup.end_time / setup.time_step));
  const PairCoefficients& coefficients = scene.pair(p.material[0], p.material[1]);
  // A JKR contact holds the pair past zero overlap until this (negative) overlap; 0 otherwise.
  const double release = separation_overlap(coefficients, first.radius * second.radius / reach);
  const bool held_by_jkr = coefficients.cohesion == CohesionModel::kJkr;

  CollisionResult result;
  double previous_overlap = 0.0;
  bool was_in_contact = false;
  for (std::int64_t s = 0; s < steps; ++s) {
    stepper.step();
    const Eigen::Vector3d separation(p.x[1] - p.x[0], p.y[1] - p.y[0], p.z[1] - p.z[0]);
    const double distance = separation.norm();
    const Eigen::Vector3d n = separation / distance;
    const double overlap = reach - distance;
    const double rate =
        -((p.vx[1] - p.vx[0]) * n.x() + (p.vy[1] - p.vy[0]) * n.y() + (p.vz[1] - p.vz[0]) * n.z());
    const bool bonded = stepper.contacts().bonds > 0;
    // The kernel's own decision, so that a JKR contact ends where the force law lets it go.
    const bool in_contact = stepper.contacts().contacts > 0;
    result.bond_formed = result.bond_formed || bonded;
    result.max_overlap = std::max(result.max_overlap, overlap);
    if (trace) {
      const double force = p.fx[0] * n.x() + p.fy[0] * n.y() + p.fz[0] * n.z();
      trace({stepper.time(), overlap, rate, force, bonded});
    }
    if (!in_contact && was_in_contact) {
      // The contact ended between the last two steps; interpolate the crossing of the release
      // overlap. The pair is force-free from here on: the rate is the separation speed.
      const double fraction = (previous_overlap - release) / (previous_overlap - overlap);
      result.contact_time = stepper.time() - (1.0 - fraction) * setup.time_step;
      result.restitution = -rate / velocity;
      result.bonded = false;
      result.stuck = false;
      result.final_overlap = 0.0;
      return result;
    }
    was_in_contact = in_contact;
    previous_overlap = overlap;
    result.bonded = bonded;
    result.stuck = in_contact && (bonded || held_by_jkr);
    result.final_overlap = in_contact ? overlap : 0.0;
  }
  return result;  // the contact did not end: restitution 0, no contact time
}

std::optional<StickingThreshold> sticking_threshold(const Case& description, double low,
                                                    double high, double precision) {
  // Sticking is monotone in the impact speed on either side: a bond forms once the overlap
  // passes delta_crit (fast impacts), a JKR contact holds while the kinetic energy is below its
  // hysteresis loss (slow impacts).
  const bool sticks_below = collide(description, low).stuck;
  if (sticks_below == collide(description, high).stuck) return std::nullopt;
  while (high - low > precision * high) {
    const double mid = 0.5 * (low + high);
    (collide(description, mid).stuck == sticks_below ? low : high) = mid;
  }
  return StickingThreshold{0.5 * (low + high), sticks_below};
}

}  // namespace bondem
