#pragma once
/// @file bodies.hpp
/// Moving rigid tools: a shape (one of geometry/tool_shapes.hpp) carried with prescribed velocity
/// over time. They push particles but are not pushed back (infinite mass). The free functions
/// here dispatch to the tool's shape; adding a shape does not change this file.

#include <Eigen/Core>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "geometry/domain.hpp"
#include "geometry/tool_shapes.hpp"

namespace bondem {

/// From @p time on (until the next key), the body moves at @p velocity.
struct MotionKey {
  double time = 0.0;
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
};

/// A rigid tool with prescribed motion.
struct Body {
  ToolShapes shape;  ///< in the body's frame, relative to center
  std::string name;
  int material = 0;
  Eigen::Vector3d center = Eigen::Vector3d::Zero();  ///< reference point the motion carries
  std::vector<MotionKey> motion;  ///< sorted by time; before the first key the body rests
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  ///< current translational velocity
};

/// Prescribed velocity of @p body at @p time: that of the last key not after it.
inline Eigen::Vector3d velocity_at(const Body& body, double time) {
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  for (const MotionKey& key : body.motion) {
    if (key.time > time) break;
    v = key.velocity;
  }
  return v;
}

/// Nearest surface point of @p body to centre @p c.
inline SurfacePoint nearest_surface(const Body& body, const Eigen::Vector3d& c) {
  return std::visit([&](const auto& shape) { return shape.nearest(c - body.center); }, body.shape);
}

/// True when a sphere of radius @p r centred at @p c cannot touch @p body: the same test as
/// nearest_surface(body, c).gap >= r, decided on squared distances without a root or a division.
inline bool surely_apart(const Body& body, const Eigen::Vector3d& c, double r) {
  return std::visit([&](const auto& shape) { return shape.surely_apart(c - body.center, r); },
                    body.shape);
}

/// Velocity of the body's surface material at @p point (translation plus spin).
inline Eigen::Vector3d surface_velocity(const Body& body, const Eigen::Vector3d& point) {
  return std::visit(
      [&](const auto& shape) { return shape.surface_velocity(point - body.center, body.velocity); },
      body.shape);
}

/// Fastest surface speed the body's own rotation adds to its translation [m/s].
inline double spin_speed(const Body& body) {
  return std::visit([](const auto& shape) { return shape.spin_speed(); }, body.shape);
}

/// The body's surface at its current position, for VTK (@p domain bounds unbounded shapes).
inline Outline outline(const Body& body, const Domain& domain) {
  return std::visit([&](const auto& shape) { return shape.outline(body.center, domain); },
                    body.shape);
}

}  // namespace bondem
