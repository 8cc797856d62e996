#pragma once
/// @file box.hpp
/// Axis-aligned box regions (insertion regions, measurement regions).

#include <Eigen/Core>

namespace bondem {

/// Axis-aligned box region [min, max].
struct Box {
  Eigen::Vector3d min = Eigen::Vector3d::Zero();
  Eigen::Vector3d max = Eigen::Vector3d::Zero();

  /// Whether point @p p lies inside (bounds included).
  bool contains(const Eigen::Vector3d& p) const {
    return (p.array() >= min.array()).all() && (p.array() <= max.array()).all();
  }
  /// Volume [m^3].
  double volume() const { return (max - min).prod(); }
};

}  // namespace bondem
