#pragma once
/// @file domain.hpp
/// The simulation box: bounds of the cell grid and the periodic axes.

#include <Eigen/Core>
#include <array>
#include <cmath>

namespace bondem {

/// Axis-aligned simulation box. Periodic axes wrap; on the others particles may leave the box
/// (the cell grid clamps them into its edge cells, which keeps the neighbor search exact).
struct Domain {
  Eigen::Vector3d min = Eigen::Vector3d::Zero();
  Eigen::Vector3d max = Eigen::Vector3d::Zero();
  std::array<bool, 3> periodic{false, false, false};
  /// Remove a particle whose centre has left the box across a face of a non-periodic axis (at
  /// the next neighbor-list build): powder falling off a build plate, out of a hopper.
  bool remove_outside = false;

  /// Whether @p x lies outside the box on a non-periodic axis.
  bool outside(const Eigen::Vector3d& x) const {
    for (int a = 0; a < 3; ++a) {
      if (!periodic[a] && (x[a] < min[a] || x[a] > max[a])) return true;
    }
    return false;
  }

  /// Edge lengths.
  Eigen::Vector3d length() const { return max - min; }
  /// Whether any axis is periodic.
  bool any_periodic() const { return periodic[0] || periodic[1] || periodic[2]; }
};

/// Map coordinate @p x of a periodic axis into [lo, lo + length).
inline double wrap_periodic(double x, double lo, double length) {
  double wrapped = x - length * std::floor((x - lo) / length);
  // floor() can land exactly on lo + length through round-off.
  return wrapped >= lo + length ? wrapped - length : wrapped;
}

}  // namespace bondem
