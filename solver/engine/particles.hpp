#pragma once
/// @file particles.hpp
/// Particle storage as a structure of arrays: one contiguous array per field.

#include <omp.h>

#include <algorithm>
#include <cstdint>
#include <initializer_list>
#include <vector>

namespace bondem {

/// Below this many particles loops run on one thread: forking a team costs more than the work,
/// and idle threads spinning at barriers starve other processes. Results do not depend on it.
/// Measured on 2 cores: 2 threads already run the 1 100- and 2 000-particle packing cases 1.3 and
/// 1.4 times faster than one.
inline constexpr std::size_t kMinParallelParticles = 1024;

/// Threads the loops over @p particles particles actually use.
inline int threads_in_use(std::size_t particles) {
  return particles >= kMinParallelParticles ? omp_get_max_threads() : 1;
}

/// Per-particle state. Index i addresses the same particle in every array; `id` is the stable
/// identity that survives reordering.
struct Particles {
  std::vector<std::int64_t> id;
  std::vector<std::int32_t> material;
  std::vector<double> x, y, z;
  std::vector<double> vx, vy, vz;
  std::vector<double> fx, fy, fz;
  std::vector<double> radius, mass;
  std::vector<double> wx, wy, wz;  ///< angular velocity [rad/s]
  std::vector<double> tx, ty, tz;  ///< torque [N m]
  /// Tangential spring elongation against each wall, 3 values per wall, wall_count() per particle.
  std::vector<double> wall_slip;
  int walls = 0;  ///< walls with a slot in wall_slip
  // Thermal state; these arrays are empty when the case has no `thermal:` block.
  std::vector<double> temperature;        ///< [K]
  std::vector<double> peak_temperature;   ///< highest temperature reached so far [K]
  std::vector<double> inv_heat_capacity;  ///< 1 / (m c_p) [K/J]
  std::vector<double> heat_rate;          ///< net heat flow in, from the last evaluation [W]

  /// Whether temperatures are tracked.
  bool thermal() const { return !temperature.empty(); }

  /// Give every particle a zeroed tangential-history slot for each of @p wall_count walls.
  void set_wall_count(int wall_count) {
    walls = wall_count;
    wall_slip.assign(size() * static_cast<std::size_t>(3 * wall_count), 0.0);
  }

  /// Number of particles.
  std::size_t size() const { return id.size(); }
  /// 1 / m of particle i, computed rather than stored: a division per particle and half-kick is
  /// nothing next to the contacts, and it saves 8 bytes per particle.
  double inverse_mass(std::size_t i) const { return 1.0 / mass[i]; }
  /// 1 / I of particle i, a solid sphere: I = 2/5 m r^2.
  double inverse_inertia(std::size_t i) const {
    return 1.0 / (0.4 * mass[i] * radius[i] * radius[i]);
  }

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
    for (std::vector<double>* field : {&wx, &wy, &wz, &tx, &ty, &tz}) field->push_back(0.0);
    wall_slip.resize(wall_slip.size() + static_cast<std::size_t>(3 * walls), 0.0);
    return id.size() - 1;
  }

  /// Reorder every array so that new index k holds old particle order[k].
  void permute(const std::vector<std::uint32_t>& order) {
    permute_field(id, order);
    permute_field(material, order);
    for (std::vector<double>* field : {&x,
                                       &y,
                                       &z,
                                       &vx,
                                       &vy,
                                       &vz,
                                       &fx,
                                       &fy,
                                       &fz,
                                       &radius,
                                       &mass,
                                       &wx,
                                       &wy,
                                       &wz,
                                       &tx,
                                       &ty,
                                       &tz,
                                       &temperature,
                                       &peak_temperature,
                                       &inv_heat_capacity,
                                       &heat_rate}) {
      if (!field->empty()) permute_field(*field, order);
    }
    const auto stride = static_cast<std::size_t>(3 * walls);
    std::vector<double> slip(wall_slip.size());
    for (std::size_t k = 0; k < order.size(); ++k) {
      std::copy_n(wall_slip.begin() + static_cast<std::ptrdiff_t>(order[k] * stride), stride,
                  slip.begin() + static_cast<std::ptrdiff_t>(k * stride));
    }
    wall_slip.swap(slip);
  }

 private:
  template <class T>
  static void permute_field(std::vector<T>& field, const std::vector<std::uint32_t>& order) {
    std::vector<T> reordered(field.size());
    for (std::size_t k = 0; k < order.size(); ++k) reordered[k] = field[order[k]];
    field.swap(reordered);
  }
};

/// Copies into @p to the fields a final-state file holds (ids, positions, velocities, radii):
/// the last good state kept for a blow-up report, at about a third of the memory of a full copy.
inline void keep_last_good(const Particles& from, Particles& to) {
  to.id = from.id;
  to.x = from.x;
  to.y = from.y;
  to.z = from.z;
  to.vx = from.vx;
  to.vy = from.vy;
  to.vz = from.vz;
  to.radius = from.radius;
}

}  // namespace bondem
