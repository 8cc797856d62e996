#pragma once
/// @file particles.hpp
/// Particle storage as a structure of arrays: one contiguous array per field.

#include <cstdint>
#include <vector>

namespace bondem {

/// Per-particle state. Index i addresses the same particle in every array; `id` is the stable
/// identity that survives reordering.
struct Particles {
  std::vector<std::int64_t> id;
  std::vector<std::int32_t> material;
  std::vector<double> x, y, z;
  std::vector<double> vx, vy, vz;
  std::vector<double> fx, fy, fz;
  std::vector<double> radius, mass, inv_mass;

  /// Number of particles.
  std::size_t size() const { return id.size(); }

  /// Append one particle at rest force-wise; returns its index.
  std::size_t add(std::int64_t particle_id, std::int32_t material_index, double particle_radius,
                  double particle_mass, const double position[3], const double velocity[3]) {
    id.push_back(particle_id);
    material.push_back(material_index);
    x.push_back(position[0]);
    y.push_back(position[1]);
    z.push_back(position[2]);
    vx.push_back(velocity[0]);
    vy.push_back(velocity[1]);
    vz.push_back(velocity[2]);
    fx.push_back(0.0);
    fy.push_back(0.0);
    fz.push_back(0.0);
    radius.push_back(particle_radius);
    mass.push_back(particle_mass);
    inv_mass.push_back(1.0 / particle_mass);
    return id.size() - 1;
  }
};

}  // namespace bondem
