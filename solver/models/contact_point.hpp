#pragma once
/// @file contact_point.hpp
/// Contact geometry and kinematics of two spheres, or of a sphere on a rigid surface: overlap,
/// approach rate, levers from the centres to the contact point and the velocity there.
/// Pure functions: no I/O, no allocation. n_ij is the unit normal from particle i toward j (for a
/// surface: from the particle into the surface).

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace bondem {

/// Overlap r_i + r_j - |x_j - x_i| of two spheres at centre distance @p distance [m]; > 0 in
/// contact.
inline double pair_overlap(double r_i, double r_j, double distance) {
  return r_i + r_j - distance;
}

/// Overlap r - gap of a sphere whose centre is @p gap from a surface [m]; > 0 in contact.
inline double surface_overlap(double radius, double gap) {
  return radius - gap;
}

/// d(delta)/dt = -(v_j - v_i) . n_ij from the relative velocity (@p dvx, @p dvy, @p dvz) = v_j -
/// v_i; positive while the spheres approach [m/s].
inline double approach_rate(double dvx, double dvy, double dvz, double nx, double ny, double nz) {
  return -(dvx * nx + dvy * ny + dvz * nz);
}

/// d(delta)/dt of a sphere moving at @p velocity on a surface moving at @p surface_velocity, with
/// @p normal the unit normal from the surface to the centre; positive while they approach [m/s].
inline double surface_approach_rate(const Eigen::Vector3d& velocity,
                                    const Eigen::Vector3d& surface_velocity,
                                    const Eigen::Vector3d& normal) {
  return -(velocity - surface_velocity).dot(normal);
}

/// Lever length from a sphere's centre to the contact point of a pair, the middle of the overlap:
/// r - delta/2 along n_ij from i (and along -n_ij from j) [m].
inline double pair_lever(double radius, double overlap) {
  return radius - 0.5 * overlap;
}

/// Lever length from a sphere's centre to the contact point on a rigid surface, which lies on the
/// surface: r - delta [m].
inline double surface_lever(double radius, double overlap) {
  return radius - overlap;
}

/// Velocity of j's surface relative to i's at the contact point, each sphere seen at its lever
/// vector (centre to contact point) @p lever_i, @p lever_j and spinning at @p spin_i, @p spin_j.
inline Eigen::Vector3d contact_velocity(const Eigen::Vector3d& velocity_i,
                                        const Eigen::Vector3d& spin_i,
                                        const Eigen::Vector3d& lever_i,
                                        const Eigen::Vector3d& velocity_j,
                                        const Eigen::Vector3d& spin_j,
                                        const Eigen::Vector3d& lever_j) {
  return velocity_j + spin_j.cross(lever_j) - velocity_i - spin_i.cross(lever_i);
}

/// Velocity of a surface moving at @p surface_velocity relative to a sphere's surface at the
/// contact point, the sphere seen at lever vector @p lever and spinning at @p spin.
inline Eigen::Vector3d surface_contact_velocity(const Eigen::Vector3d& velocity,
                                                const Eigen::Vector3d& spin,
                                                const Eigen::Vector3d& lever,
                                                const Eigen::Vector3d& surface_velocity) {
  return surface_velocity - (velocity + spin.cross(lever));
}

/// Torque per metre of lever of a tangential force @p force acting at the contact point of a pair:
/// n_ij x F_t. Particle i sits at lever L_i n_ij and j, receiving -F_t, at -L_j n_ij, so each
/// torque is its own lever length times this (see lever_torque).
inline Eigen::Vector3d torque_per_lever(const Eigen::Vector3d& normal,
                                        const Eigen::Vector3d& force) {
  return normal.cross(force);
}

/// Torque L (n_ij x F_t) on a pair member with lever length @p lever (pair_lever).
inline Eigen::Vector3d lever_torque(double lever, const Eigen::Vector3d& per_lever) {
  return lever * per_lever;
}

/// Torque lever x F of a force acting at lever vector @p lever from the centre.
inline Eigen::Vector3d moment(const Eigen::Vector3d& lever, const Eigen::Vector3d& force) {
  return lever.cross(force);
}

}  // namespace bondem
