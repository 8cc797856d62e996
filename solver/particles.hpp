#pragma once
/// @file particles.hpp
/// Particle storage as a structure of arrays: one contiguous array per field.

#include <cstdint>
#include <initializer_list>
#include <vector>

namespace bondem {

/// Below this many particles loops run on one thread: forking a team costs more than the work,
/// and idle threads spinning at barriers starve other processes. Results do not depend on it.
inline constexpr std::size_t kMinParallelParticles = 2048;

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

  /// Reorder every array so that new index k holds old particle order[k].
  void permute(const std::vector<std::uint32_t>& order) {
    permute_field(id, order);
    permute_field(material, order);
    for (std::vector<double>* field :
         {&x, &y, &z, &vx, &vy, &vz, &fx, &fy, &fz, &radius, &mass, &inv_mass}) {
      permute_field(*field, order);
    }
  }

 private:
  template <class T>
  static void permute_field(std::vector<T>& field, const std::vector<std::uint32_t>& order) {
    std::vector<T> reordered(field.size());
    for (std::size_t k = 0; k < order.size(); ++k) reordered[k] = field[order[k]];
    field.swap(reordered);
  }
};

}  // namespace bondem
