#pragma once
/// @file tool_shapes.hpp
/// The shapes of moving tools, each a small struct in the tool's own frame: positions are taken
/// relative to the tool's reference point (Body::center, the point its motion carries). Every
/// shape gives the same five things, which is all the kernel, the VTK writer and the time-step
/// limit ask of it:
///   - nearest(w): the signed gap and outward normal of the surface nearest to a sphere centre;
///   - surely_apart(w, r): a cheap test, true exactly when nearest(w).gap >= r (up to rounding);
///   - surface_velocity(w, v): the velocity of the surface material at w, the tool translating at
///   v;
///   - spin_speed(): the fastest surface speed its own rotation adds [m/s];
///   - outline(center, domain): its surface as polygons for VTK;
/// and lists its parameters (parameters(f)) for the case fingerprint.
/// To add a shape, write its struct here and add it to ToolShape; then give it one reader entry
/// (CONTRIBUTING.md, "Add a boundary shape").

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <variant>
#include <vector>

#include "geometry/domain.hpp"

namespace bondem {

/// Where a sphere centre meets a surface: the signed gap from the centre to the surface (negative
/// when the centre is inside) and the unit normal pointing from the surface toward the centre.
struct SurfacePoint {
  double gap;
  Eigen::Vector3d normal;
};

/// A surface for VTK, geometry only: points and polygons (indices into the points). Each shape
/// gives every polygon its own corners, so the files hold what they held before shapes had their
/// own structs.
struct Outline {
  std::vector<Eigen::Vector3d> points;
  std::vector<std::vector<int>> polygons;

  /// Appends a polygon with new corner points.
  void add(std::initializer_list<Eigen::Vector3d> corners) {
    std::vector<int>& polygon = polygons.emplace_back();
    for (const Eigen::Vector3d& corner : corners) {
      polygon.push_back(static_cast<int>(points.size()));
      points.push_back(corner);
    }
  }
};

/// An axis-aligned box (case-file type `blade`), centred on the reference point.
struct BoxShape {
  Eigen::Vector3d half_size = Eigen::Vector3d::Zero();  ///< half extents [m]

  /// Nearest face, edge or corner to centre @p w.
  SurfacePoint nearest(const Eigen::Vector3d& w) const {
    const Eigen::Vector3d clamped = w.cwiseMax(-half_size).cwiseMin(half_size);
    const Eigen::Vector3d outside = w - clamped;
    const double distance = outside.norm();
    if (distance > 0.0) return {distance, outside / distance};
    // Centre inside the box: leave through the nearest face.
    const Eigen::Vector3d depth = half_size - w.cwiseAbs();
    Eigen::Index axis = 0;
    depth.minCoeff(&axis);
    Eigen::Vector3d normal = Eigen::Vector3d::Zero();
    normal[axis] = w[axis] >= 0.0 ? 1.0 : -1.0;
    return {-depth[axis], normal};
  }
  /// Squared distance to the clamped point, without a root.
  bool surely_apart(const Eigen::Vector3d& w, double r) const {
    const Eigen::Vector3d clamped = w.cwiseMax(-half_size).cwiseMin(half_size);
    return (w - clamped).squaredNorm() >= r * r;
  }
  /// A box does not spin: its surface moves with the tool.
  Eigen::Vector3d surface_velocity(const Eigen::Vector3d& /*w*/, const Eigen::Vector3d& v) const {
    return v;
  }
  double spin_speed() const { return 0.0; }
  /// The six faces, x_min, x_max, y_min, y_max, z_min, z_max.
  Outline outline(const Eigen::Vector3d& center, const Domain& /*domain*/) const {
    const Eigen::Vector3d lo = center - half_size;
    const Eigen::Vector3d hi = center + half_size;
    const auto corner = [&](int i) {
      return Eigen::Vector3d((i & 1) ? hi.x() : lo.x(), (i & 2) ? hi.y() : lo.y(),
                             (i & 4) ? hi.z() : lo.z());
    };
    constexpr int kFaces[6][4] = {{0, 2, 6, 4}, {1, 5, 7, 3}, {0, 4, 5, 1},
                                  {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 6, 7, 5}};
    Outline out;
    for (const auto& face : kFaces) {
      out.add({corner(face[0]), corner(face[1]), corner(face[2]), corner(face[3])});
    }
    return out;
  }
  template <class F>
  void parameters(F&& f) const {
    f("half_size", half_size);
  }
};

/// An infinite cylinder (case-file type `roller`) whose axis passes through the reference point;
/// it may spin about its axis.
struct CylinderShape {
  Eigen::Vector3d axis = Eigen::Vector3d::UnitY();  ///< unit
  double radius = 0.0;                              ///< [m]
  double spin = 0.0;  ///< angular velocity about the axis [rad/s], right-handed

  /// Nearest point on the mantle: radial from the axis (any direction for a centre on the axis).
  SurfacePoint nearest(const Eigen::Vector3d& w) const {
    const Eigen::Vector3d radial = w - w.dot(axis) * axis;
    const double rho = radial.norm();
    const Eigen::Vector3d normal =
        rho > 0.0 ? Eigen::Vector3d(radial / rho) : axis.unitOrthogonal();
    return {rho - radius, normal};
  }
  bool surely_apart(const Eigen::Vector3d& w, double r) const {
    const double reach = radius + r;
    return (w - w.dot(axis) * axis).squaredNorm() >= reach * reach;
  }
  /// Translation plus the spin's rim velocity.
  Eigen::Vector3d surface_velocity(const Eigen::Vector3d& w, const Eigen::Vector3d& v) const {
    if (spin == 0.0) return v;
    return v + (spin * axis).cross(w);
  }
  double spin_speed() const { return std::abs(spin) * radius; }
  /// A 32-sided prism whose length spans the domain along the axis.
  Outline outline(const Eigen::Vector3d& center, const Domain& domain) const {
    const Eigen::Vector3d a = axis.normalized();
    const Eigen::Vector3d u = a.unitOrthogonal();
    const Eigen::Vector3d v = a.cross(u);
    // Span the domain along the axis: project the domain's corners on it.
    double s_min = 0.0, s_max = 0.0;
    for (int i = 0; i < 8; ++i) {
      const Eigen::Vector3d c((i & 1) ? domain.max.x() : domain.min.x(),
                              (i & 2) ? domain.max.y() : domain.min.y(),
                              (i & 4) ? domain.max.z() : domain.min.z());
      const double s = (c - center).dot(a);
      s_min = i == 0 ? s : std::min(s_min, s);
      s_max = i == 0 ? s : std::max(s_max, s);
    }
    constexpr int kSides = 32;
    Outline out;
    for (int k = 0; k < kSides; ++k) {
      const double a0 = 2.0 * std::numbers::pi * k / kSides;
      const double a1 = 2.0 * std::numbers::pi * (k + 1) / kSides;
      const Eigen::Vector3d r0 = radius * (std::cos(a0) * u + std::sin(a0) * v);
      const Eigen::Vector3d r1 = radius * (std::cos(a1) * u + std::sin(a1) * v);
      out.add({center + r0 + s_min * a, center + r1 + s_min * a, center + r1 + s_max * a,
               center + r0 + s_max * a});
    }
    return out;
  }
  template <class F>
  void parameters(F&& f) const {
    f("axis", axis);
    f("radius", radius);
    f("spin", spin);
  }
};

/// A sphere (case-file type `sphere`) centred on the reference point: an impactor, an indenter or
/// a rigid obstacle. It does not spin.
struct SphereShape {
  double radius = 0.0;  ///< [m]

  /// Radial from the centre; a particle centred exactly at the centre leaves along +z.
  SurfacePoint nearest(const Eigen::Vector3d& w) const {
    const double distance = w.norm();
    const Eigen::Vector3d normal =
        distance > 0.0 ? Eigen::Vector3d(w / distance) : Eigen::Vector3d::UnitZ();
    return {distance - radius, normal};
  }
  bool surely_apart(const Eigen::Vector3d& w, double r) const {
    const double reach = radius + r;
    return w.squaredNorm() >= reach * reach;
  }
  Eigen::Vector3d surface_velocity(const Eigen::Vector3d& /*w*/, const Eigen::Vector3d& v) const {
    return v;
  }
  double spin_speed() const { return 0.0; }
  /// 16 meridians by 8 bands: triangles at the poles (z), quadrilaterals between.
  Outline outline(const Eigen::Vector3d& center, const Domain& /*domain*/) const {
    constexpr int kMeridians = 16;
    constexpr int kBands = 8;
    const auto at = [&](int band, int meridian) {
      const double polar = std::numbers::pi * band / kBands;
      const double azimuth = 2.0 * std::numbers::pi * meridian / kMeridians;
      return Eigen::Vector3d(center + radius * Eigen::Vector3d(std::sin(polar) * std::cos(azimuth),
                                                               std::sin(polar) * std::sin(azimuth),
                                                               std::cos(polar)));
    };
    Outline out;
    for (int b = 0; b < kBands; ++b) {
      for (int m = 0; m < kMeridians; ++m) {
        if (b == 0) {
          out.add({at(0, 0), at(1, m), at(1, m + 1)});
        } else if (b == kBands - 1) {
          out.add({at(b, m), at(b + 1, 0), at(b, m + 1)});
        } else {
          out.add({at(b, m), at(b + 1, m), at(b + 1, m + 1), at(b, m + 1)});
        }
      }
    }
    return out;
  }
  template <class F>
  void parameters(F&& f) const {
    f("radius", radius);
  }
};

/// Every tool shape. The order is the shape's number in the case fingerprint: append, never
/// reorder.
using ToolShapes = std::variant<BoxShape, CylinderShape, SphereShape>;

}  // namespace bondem
