#pragma once
/// @file bodies.hpp
/// Moving rigid tools: a blade (a box) and a roller (a cylinder that may spin), with prescribed
/// velocity over time. They push particles but are not pushed back (infinite mass).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace bondem {

/// From @p time on (until the next key), the body moves at @p velocity.
struct MotionKey {
  double time = 0.0;
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
};

/// A rigid tool with prescribed motion.
struct Body {
  enum class Shape { kBox, kCylinder };
  Shape shape = Shape::kBox;
  std::string name;
  int material = 0;
  Eigen::Vector3d center = Eigen::Vector3d::Zero();     ///< box centre, or a point on the axis
  Eigen::Vector3d half_size = Eigen::Vector3d::Zero();  ///< box half extents
  Eigen::Vector3d axis = Eigen::Vector3d::UnitY();      ///< cylinder axis (unit)
  double radius = 0.0;                                  ///< cylinder radius [m]
  double spin = 0.0;              ///< cylinder angular velocity about its axis [rad/s]
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

/// Where a sphere centre meets a body: the signed gap from the centre to the surface (negative
/// when the centre is inside) and the unit normal pointing from the surface toward the centre.
struct SurfacePoint {
  double gap;
  Eigen::Vector3d normal;
};

/// Nearest surface point of @p body to centre @p c.
inline SurfacePoint nearest_surface(const Body& body, const Eigen::Vector3d& c) {
  if (body.shape == Body::Shape::kCylinder) {
    const Eigen::Vector3d w = c - body.center;
    const Eigen::Vector3d radial = w - w.dot(body.axis) * body.axis;
    const double rho = radial.norm();
    const Eigen::Vector3d normal =
        rho > 0.0 ? Eigen::Vector3d(radial / rho) : body.axis.unitOrthogonal();
    return {rho - body.radius, normal};
  }
  const Eigen::Vector3d local = c - body.center;
  const Eigen::Vector3d clamped = local.cwiseMax(-body.half_size).cwiseMin(body.half_size);
  const Eigen::Vector3d outside = local - clamped;
  const double distance = outside.norm();
  if (distance > 0.0) return {distance, outside / distance};
  // Centre inside the box: leave through the nearest face.
  const Eigen::Vector3d depth = body.half_size - local.cwiseAbs();
  Eigen::Index axis = 0;
  depth.minCoeff(&axis);
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  normal[axis] = local[axis] >= 0.0 ? 1.0 : -1.0;
  return {-depth[axis], normal};
}

/// True when a sphere of radius @p r centred at @p c cannot touch @p body: the same test as
/// nearest_surface(body, c).gap >= r, decided on squared distances without a root or a division.
inline bool surely_apart(const Body& body, const Eigen::Vector3d& c, double r) {
  const Eigen::Vector3d w = c - body.center;
  if (body.shape == Body::Shape::kCylinder) {
    const double reach = body.radius + r;
    return (w - w.dot(body.axis) * body.axis).squaredNorm() >= reach * reach;
  }
  const Eigen::Vector3d clamped = w.cwiseMax(-body.half_size).cwiseMin(body.half_size);
  return (w - clamped).squaredNorm() >= r * r;
}

/// Velocity of the body's surface material at @p point (translation plus spin).
inline Eigen::Vector3d surface_velocity(const Body& body, const Eigen::Vector3d& point) {
  if (body.shape != Body::Shape::kCylinder || body.spin == 0.0) return body.velocity;
  return body.velocity + (body.spin * body.axis).cross(point - body.center);
}

}  // namespace bondem
