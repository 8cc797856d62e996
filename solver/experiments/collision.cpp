#include "solver/experiments/collision.hpp"

#include <cmath>
#include <stdexcept>

#include "solver/engine/scene.hpp"
#include "solver/engine/stepper.hpp"

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
  ParticleSpec& first = setup.particles[0];
  ParticleSpec& second = setup.particles[1];
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

  CollisionResult result;
  double previous_overlap = 0.0;
  for (std::int64_t s = 0; s < steps; ++s) {
    stepper.step();
    const Eigen::Vector3d separation(p.x[1] - p.x[0], p.y[1] - p.y[0], p.z[1] - p.z[0]);
    const double distance = separation.norm();
    const Eigen::Vector3d n = separation / distance;
    const double overlap = reach - distance;
    const double rate =
        -((p.vx[1] - p.vx[0]) * n.x() + (p.vy[1] - p.vy[0]) * n.y() + (p.vz[1] - p.vz[0]) * n.z());
    const bool bonded = stepper.contacts().bonds > 0;
    result.bond_formed = result.bond_formed || bonded;
    result.max_overlap = std::max(result.max_overlap, overlap);
    if (trace) {
      const double force = p.fx[0] * n.x() + p.fy[0] * n.y() + p.fz[0] * n.z();
      trace({stepper.time(), overlap, rate, force, bonded});
    }
    if (overlap <= 0.0 && previous_overlap > 0.0) {
      // Separated: the contact ended between the last two steps; interpolate the crossing.
      const double fraction = previous_overlap / (previous_overlap - overlap);
      result.contact_time = stepper.time() - (1.0 - fraction) * setup.time_step;
      result.restitution = -rate / velocity;
      result.bonded = false;
      result.final_overlap = 0.0;
      return result;
    }
    previous_overlap = overlap;
    result.bonded = bonded;
    result.final_overlap = std::max(overlap, 0.0);
  }
  return result;  // still in contact at the end: restitution 0, no contact time
}

}  // namespace bondem
