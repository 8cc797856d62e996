#pragma once
/// @file energy.hpp
/// Kinetic energies of a sphere. Pure functions: no I/O, no allocation.

namespace bondem {

/// Kinetic energy of translation (m/2) |v|^2 of a body of @p mass [J].
inline double translational_energy(double mass, double vx, double vy, double vz) {
  return 0.5 * mass * (vx * vx + vy * vy + vz * vz);
}

/// Kinetic energy of rotation (I/2) |omega|^2 of a sphere with inverse moment of inertia
/// @p inverse_inertia [J].
inline double rotational_energy(double inverse_inertia, double wx, double wy, double wz) {
  return 0.5 / inverse_inertia * (wx * wx + wy * wy + wz * wz);
}

}  // namespace bondem
