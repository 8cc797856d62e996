#pragma once
/// @file boundary_shapes.hpp
/// The shapes of boundaries, each a small struct in the boundary's own frame: positions are taken
/// relative to the boundary's reference point (Boundary::center, the point its motion carries and
/// its rotation turns about) and in its unrotated orientation. Every analytic shape gives the same
/// four things, which is all the kernel, the VTK writer and the time-step limit ask of it:
///   - nearest(w): the signed gap and outward normal of the surface nearest to a sphere centre;
///   - surely_apart(w, r): a cheap test, true exactly when nearest(w).gap >= r (up to rounding);
///   - rotation_reach(): the farthest surface point from the reference point [m] (infinite for an
///     unbounded shape), which bounds the surface speed a rotation adds;
///   - outline(center, domain): its surface as polygons for VTK;
///   - kTurnsWithRotation: whether its geometry turns when the boundary rotates (false for a shape
///     that looks the same at every angle of the rotations it may take: then only its surface
///     velocity sees the rotation);
/// and lists its parameters (parameters(f)) for the case fingerprint. A triangle mesh
/// (MeshShape) gives several contacts instead of one nearest point: see triangle_mesh.hpp.
/// To add a shape, write its struct here and add it to BoundaryShapes; then give it one reader
/// entry (CONTRIBUTING.md, "Add a boundary shape").

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <string>
#include <variant>
#include <vector>

#include "geometry/domain.hpp"
#include "geometry/triangle_mesh.hpp"

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
  static constexpr bool kTurnsWithRotation = true;

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
  /// Its corners.
  double rotation_reach() const { return half_size.norm(); }
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
/// it may rotate about that axis only (the reader refuses any other rotation).
struct CylinderShape {
  Eigen::Vector3d axis = Eigen::Vector3d::UnitY();   ///< unit
  double radius = 0.0;                               ///< [m]
  static constexpr bool kTurnsWithRotation = false;  ///< it turns about its own axis only

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
  /// Its mantle, for a rotation about its own axis.
  double rotation_reach() const { return radius; }
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
  }
};

/// A sphere (case-file type `sphere`) centred on the reference point: an impactor, an indenter or
/// a rigid obstacle. It does not spin.
struct SphereShape {
  double radius = 0.0;                               ///< [m]
  static constexpr bool kTurnsWithRotation = false;  ///< about its centre

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
  double rotation_reach() const { return radius; }
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

/// An infinite plane (case-file type `plane`, and the six faces of a `box` container) through the
/// reference point; particles live on the side its normal points to.
struct PlaneShape {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< unit, into the domain
  static constexpr bool kTurnsWithRotation = false;   ///< it may not rotate

  /// Signed distance along the normal, written out term by term: one summation order, the same
  /// as the walls' before boundaries were one kind.
  SurfacePoint nearest(const Eigen::Vector3d& w) const {
    return {w.x() * normal.x() + w.y() * normal.y() + w.z() * normal.z(), normal};
  }
  bool surely_apart(const Eigen::Vector3d& w, double r) const { return nearest(w).gap >= r; }
  /// Unbounded: a plane may only translate (the reader refuses a rotation).
  double rotation_reach() const { return std::numeric_limits<double>::infinity(); }
  /// A plane is drawn by the VTK writer's wall file (clipped to the domain), not as an outline.
  Outline outline(const Eigen::Vector3d& /*center*/, const Domain& /*domain*/) const { return {}; }
  template <class F>
  void parameters(F&& f) const {
    f("normal", normal);
  }
};

/// A triangle surface with its cell grid, in the boundary's frame, built once and shared by the
/// copies of a case and its scene (it never changes: motion moves the frame, not the vertices).
struct MeshSurface {
  TriangleMesh mesh;
  TriangleGrid grid;
  Eigen::Vector3d box_min = Eigen::Vector3d::Zero();  ///< bounding box of the vertices
  Eigen::Vector3d box_max = Eigen::Vector3d::Zero();
  double reach = 0.0;    ///< farthest vertex from the reference point [m]
  std::string file;      ///< where it was read from (for reports)
  std::string checksum;  ///< FNV-1a of the vertices and triangles, hex (case fingerprint)
};

/// Build a MeshSurface from @p mesh (in the boundary frame; normals are computed) with grid cells
/// of about @p cell_size [m], or of its longest edge when @p cell_size is 0.
std::shared_ptr<const MeshSurface> make_mesh_surface(TriangleMesh mesh, double cell_size,
                                                     std::string file);

/// A triangle mesh (case-file type `mesh`, from an STL file). Two-sided: a sphere is pushed away
/// from the nearest surface on whichever side it is, so the facets' winding does not matter.
struct MeshShape {
  std::shared_ptr<const MeshSurface> surface;
  static constexpr bool kTurnsWithRotation = true;

  /// Whether a sphere (centre @p w, radius @p r) misses the mesh's bounding box.
  bool surely_apart(const Eigen::Vector3d& w, double r) const {
    const Eigen::Vector3d below = (surface->box_min - w).cwiseMax(0.0);
    const Eigen::Vector3d above = (w - surface->box_max).cwiseMax(0.0);
    return (below + above).squaredNorm() >= r * r;
  }
  double rotation_reach() const { return surface->reach; }
  /// Its triangles at the pose (center, rotation).
  Outline outline(const Eigen::Vector3d& center, const Eigen::Matrix3d& rotation) const {
    Outline out;
    out.points.reserve(surface->mesh.vertices.size());
    for (const Eigen::Vector3d& v : surface->mesh.vertices)
      out.points.push_back(center + rotation * v);
    for (const auto& t : surface->mesh.triangles) out.polygons.push_back({t[0], t[1], t[2]});
    return out;
  }
  template <class F>
  void parameters(F&& f) const {
    f("file", std::string_view(surface->file));
    f("triangles", static_cast<int>(surface->mesh.triangles.size()));
    f("checksum", std::string_view(surface->checksum));
  }
};

/// Every boundary shape. The order is the shape's number in the case fingerprint: append, never
/// reorder.
using BoundaryShapes = std::variant<BoxShape, CylinderShape, SphereShape, PlaneShape, MeshShape>;

}  // namespace bondem
