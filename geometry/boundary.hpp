#pragma once
/// @file boundary.hpp
/// Boundaries: walls, containers, tools and meshes as one kind. A boundary is a shape (one of
/// geometry/boundary_shapes.hpp) with a material, an optional held temperature, a name and a
/// prescribed motion: a translation velocity and a rotation rate about a fixed axis through its
/// reference point, each given as a table over time. Boundaries push particles but are not pushed
/// back (infinite mass). The free functions here dispatch to the shape; adding a shape does not
/// change this file.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "geometry/boundary_shapes.hpp"
#include "geometry/domain.hpp"

namespace bondem {

/// Slots of contact history a particle has per mesh boundary: the contacts a sphere can have with
/// one mesh after the double-contact rule (triangle_mesh.hpp): one on a flat or convex region, one
/// per face in a concave corner (three in a box corner). Contacts beyond are dropped, last in the
/// rule's order (faces first, nearest first).
inline constexpr int kMeshContactSlots = 4;

/// From @p time on (until the next key), the boundary moves at @p velocity and turns at
/// @p angular_velocity about its rotation axis (or, with linear interpolation, heads for the next
/// key's values).
struct MotionKey {
  double time = 0.0;
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  double angular_velocity = 0.0;  ///< [rad/s], right-handed about Motion::axis
};

/// How a motion table is read between its keys.
enum class MotionInterpolation : std::uint8_t {
  kConstant,  ///< each key's values hold until the next key (a step profile)
  kLinear,    ///< values change linearly from key to key (a ramp), then hold after the last
};

/// Prescribed motion: a table of keys over time (before the first key the boundary rests) plus a
/// constant spin, both about one axis through the reference point.
struct Motion {
  std::vector<MotionKey> keys;  ///< sorted by time
  MotionInterpolation interpolation = MotionInterpolation::kConstant;
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  ///< unit rotation axis (body frame = world)
  double spin = 0.0;  ///< constant angular velocity added to the table's [rad/s]

  /// Whether the boundary ever turns.
  bool rotates() const {
    if (spin != 0.0) return true;
    for (const MotionKey& key : keys) {
      if (key.angular_velocity != 0.0) return true;
    }
    return false;
  }
  /// Whether it ever moves at all.
  bool moves() const {
    if (rotates()) return true;
    for (const MotionKey& key : keys) {
      if (key.velocity != Eigen::Vector3d::Zero()) return true;
    }
    return false;
  }
};

/// Velocity and angular velocity of a motion at one time.
struct MotionState {
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  double angular_velocity = 0.0;
};

/// The motion's values at @p time: the last key not after it (constant), or the ramp between it
/// and the next key (linear); zero before the first key; plus the constant spin.
inline MotionState motion_at(const Motion& motion, double time) {
  MotionState state;
  const std::vector<MotionKey>& keys = motion.keys;
  std::size_t k = 0;
  while (k < keys.size() && keys[k].time <= time) ++k;
  if (k > 0) {
    const MotionKey& from = keys[k - 1];
    state.velocity = from.velocity;
    state.angular_velocity = from.angular_velocity;
    if (motion.interpolation == MotionInterpolation::kLinear && k < keys.size()) {
      const MotionKey& to = keys[k];
      const double s = (time - from.time) / (to.time - from.time);
      state.velocity = from.velocity + s * (to.velocity - from.velocity);
      state.angular_velocity =
          from.angular_velocity + s * (to.angular_velocity - from.angular_velocity);
    }
  }
  state.angular_velocity += motion.spin;
  return state;
}

/// A wall, container face, tool or mesh.
struct Boundary {
  BoundaryShapes shape;      ///< in the boundary's frame, relative to center, unrotated
  std::string name;          ///< for reports, e.g. "box.z_min" or "blade"
  int material = 0;          ///< index into the case's materials: selects the pair's contact model
  double temperature = 0.0;  ///< held temperature [K] for heat exchange; 0: adiabatic
  Motion motion;
  // The pose, advanced by the stepper and saved in checkpoints.
  Eigen::Vector3d center = Eigen::Vector3d::Zero();    ///< reference point the motion carries
  double angle = 0.0;                                  ///< turned so far about motion.axis [rad]
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  ///< current translational velocity
  double angular_velocity = 0.0;                       ///< current rate about motion.axis

  /// Whether the shape's geometry turns with the rotation (a mesh or a box does; a cylinder about
  /// its own axis and a sphere about its centre look the same at every angle, and only their
  /// surface velocity sees the rotation).
  bool turns() const {
    return motion.rotates() &&
           std::visit([](const auto& s) { return s.kTurnsWithRotation; }, shape);
  }
  /// Rotation from the boundary frame to the world at the current angle.
  Eigen::Matrix3d rotation() const {
    return Eigen::AngleAxisd(angle, motion.axis).toRotationMatrix();
  }
};

/// Whether @p boundary's top is one level plane, something a bed can stand on: a box that does
/// not turn, or a plane whose normal is +z.
inline bool has_level_top(const Boundary& boundary) {
  if (std::holds_alternative<BoxShape>(boundary.shape)) return !boundary.motion.rotates();
  if (const auto* plane = std::get_if<PlaneShape>(&boundary.shape)) {
    return plane->normal == Eigen::Vector3d::UnitZ();
  }
  return false;
}

/// Height of the level top of @p boundary at its current pose (has_level_top() must hold) [m].
inline double level_top(const Boundary& boundary) {
  if (const auto* box = std::get_if<BoxShape>(&boundary.shape)) {
    return boundary.center.z() + box->half_size.z();
  }
  return boundary.center.z();
}

/// Advance @p boundary over the step [time, time + dt] by its motion table.
inline void move_boundary(Boundary& boundary, double time, double dt) {
  const Motion& motion = boundary.motion;
  if (motion.keys.empty() && motion.spin == 0.0) return;  // fixed
  // A step profile is read at the start of the step, so that it changes exactly at its keys; a
  // ramp at the middle, whose value is the ramp's exact mean over a step within one segment.
  const double at = motion.interpolation == MotionInterpolation::kLinear ? time + 0.5 * dt : time;
  const MotionState state = motion_at(motion, at);
  boundary.velocity = state.velocity;
  boundary.angular_velocity = state.angular_velocity;
  boundary.center += dt * boundary.velocity;
  boundary.angle += dt * boundary.angular_velocity;
}

/// A boundary as a sphere centre sees it: the centre in the boundary frame, and the rotation back.
struct BoundaryFrame {
  bool turned = false;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< boundary frame to world

  /// @p c relative to the boundary's reference point @p center, in the boundary frame.
  Eigen::Vector3d to_body(const Eigen::Vector3d& c, const Eigen::Vector3d& center) const {
    const Eigen::Vector3d w = c - center;
    return turned ? Eigen::Vector3d(rotation.transpose() * w) : w;
  }
  /// A direction of the boundary frame in the world.
  Eigen::Vector3d to_world(const Eigen::Vector3d& direction) const {
    return turned ? Eigen::Vector3d(rotation * direction) : direction;
  }
};

/// The frame of @p boundary at its current pose.
inline BoundaryFrame frame_of(const Boundary& boundary) {
  BoundaryFrame frame;
  frame.turned = boundary.turns();
  if (frame.turned) frame.rotation = boundary.rotation();
  return frame;
}

/// Nearest surface point of analytic (non-mesh) @p boundary to centre @p c, in the world.
inline SurfacePoint nearest_surface(const Boundary& boundary, const Eigen::Vector3d& c) {
  const BoundaryFrame frame = frame_of(boundary);
  const Eigen::Vector3d w = frame.to_body(c, boundary.center);
  return std::visit(
      [&](const auto& shape) -> SurfacePoint {
        if constexpr (std::is_same_v<std::decay_t<decltype(shape)>, MeshShape>) {
          MeshQueryBuffer buffer;
          const double far = (shape.surface->box_max - shape.surface->box_min).norm() + w.norm();
          const auto contacts =
              mesh_contacts(shape.surface->mesh, shape.surface->grid, w, far, buffer);
          if (contacts.empty()) return {far, Eigen::Vector3d::UnitZ()};
          const MeshContact* nearest = &contacts[0];
          for (const MeshContact& contact : contacts) {
            if (contact.gap < nearest->gap) nearest = &contact;
          }
          return {nearest->gap, frame.to_world(nearest->normal)};
        } else {
          const SurfacePoint local = shape.nearest(w);
          return {local.gap, frame.to_world(local.normal)};
        }
      },
      boundary.shape);
}

/// Whether a sphere of radius @p r centred at @p c overlaps @p boundary (a mesh: some triangle is
/// nearer than r, found through its grid without a search of the whole mesh).
inline bool overlaps(const Boundary& boundary, const Eigen::Vector3d& c, double r) {
  const BoundaryFrame frame = frame_of(boundary);
  const Eigen::Vector3d w = frame.to_body(c, boundary.center);
  return std::visit(
      [&](const auto& shape) {
        if (shape.surely_apart(w, r)) return false;
        if constexpr (std::is_same_v<std::decay_t<decltype(shape)>, MeshShape>) {
          MeshQueryBuffer buffer;
          return !mesh_contacts(shape.surface->mesh, shape.surface->grid, w, r, buffer).empty();
        } else {
          return shape.nearest(w).gap < r;
        }
      },
      boundary.shape);
}

/// True when a sphere of radius @p r centred at @p c cannot touch @p boundary: decided on squared
/// distances without a root or a division (for a mesh, against its bounding box).
inline bool surely_apart(const Boundary& boundary, const Eigen::Vector3d& c, double r) {
  const Eigen::Vector3d w = frame_of(boundary).to_body(c, boundary.center);
  return std::visit([&](const auto& shape) { return shape.surely_apart(w, r); }, boundary.shape);
}

/// Velocity of the boundary's surface material at world point @p point (translation plus turn).
inline Eigen::Vector3d surface_velocity(const Boundary& boundary, const Eigen::Vector3d& point) {
  if (boundary.angular_velocity == 0.0) return boundary.velocity;
  return boundary.velocity +
         (boundary.angular_velocity * boundary.motion.axis).cross(point - boundary.center);
}

/// Fastest surface speed the boundary's rotation ever adds to its translation [m/s].
inline double rotation_speed(const Boundary& boundary) {
  if (!boundary.motion.rotates()) return 0.0;
  double fastest = std::abs(boundary.motion.spin);
  for (const MotionKey& key : boundary.motion.keys) {
    fastest = std::max(fastest, std::abs(key.angular_velocity + boundary.motion.spin));
  }
  return fastest *
         std::visit([](const auto& shape) { return shape.rotation_reach(); }, boundary.shape);
}

/// The boundary's surface at its current pose, for VTK (@p domain bounds unbounded shapes).
inline Outline outline(const Boundary& boundary, const Domain& domain) {
  return std::visit(
      [&](const auto& shape) {
        if constexpr (std::is_same_v<std::decay_t<decltype(shape)>, MeshShape>) {
          return shape.outline(boundary.center, frame_of(boundary).rotation);
        } else if constexpr (std::is_same_v<std::decay_t<decltype(shape)>, BoxShape>) {
          if (boundary.turns()) {
            Outline out = shape.outline(Eigen::Vector3d::Zero(), domain);
            const Eigen::Matrix3d rotation = boundary.rotation();
            for (Eigen::Vector3d& p : out.points) p = boundary.center + rotation * p;
            return out;
          }
          return shape.outline(boundary.center, domain);
        } else {
          return shape.outline(boundary.center, domain);
        }
      },
      boundary.shape);
}

/// Whether @p boundary is a plane.
inline bool is_plane(const Boundary& boundary) {
  return std::holds_alternative<PlaneShape>(boundary.shape);
}

/// A static plane through @p point with unit inward @p normal.
inline Boundary plane_boundary(const Eigen::Vector3d& point, const Eigen::Vector3d& normal,
                               int material, std::string name, double temperature = 0.0) {
  Boundary plane;
  plane.shape = PlaneShape{normal};
  plane.center = point;
  plane.material = material;
  plane.name = std::move(name);
  plane.temperature = temperature;
  return plane;
}

/// A static mesh boundary: @p mesh with its vertices in world coordinates, carried and turned
/// about @p center.
inline Boundary mesh_boundary(TriangleMesh mesh, const Eigen::Vector3d& center, int material,
                              std::string name) {
  for (Eigen::Vector3d& v : mesh.vertices) v -= center;
  Boundary boundary;
  boundary.shape = MeshShape{make_mesh_surface(std::move(mesh), 0.0, name)};
  boundary.center = center;
  boundary.material = material;
  boundary.name = std::move(name);
  return boundary;
}

/// A plane boundary's current point and world normal (for VTK and reports).
struct PlaneWall {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< unit, into the domain
  int material = 0;
  std::string name;
};

/// @p plane (a PlaneShape boundary) at its current pose.
inline PlaneWall plane_of(const Boundary& plane) {
  return {plane.center, std::get<PlaneShape>(plane.shape).normal, plane.material, plane.name};
}

/// Faces of an axis-aligned box, in the order x_min, x_max, y_min, y_max, z_min, z_max.
inline constexpr const char* kBoxFaceNames[6] = {"x_min", "x_max", "y_min",
                                                 "y_max", "z_min", "z_max"};

/// A box container [min, max]: its inward-facing planes, one boundary each (so each face has its
/// own load and contact history); faces whose flag in @p open is set are left out.
inline std::vector<Boundary> box_container(const Eigen::Vector3d& min, const Eigen::Vector3d& max,
                                           int material, const bool open[6],
                                           const std::string& name = "box") {
  std::vector<Boundary> faces;
  for (int face = 0; face < 6; ++face) {
    if (open[face]) continue;
    const int axis = face / 2;
    const bool upper = face % 2 == 1;
    Eigen::Vector3d normal = Eigen::Vector3d::Zero();
    normal[axis] = upper ? -1.0 : 1.0;
    faces.push_back(
        plane_boundary(upper ? max : min, normal, material, name + "." + kBoxFaceNames[face]));
  }
  return faces;
}

}  // namespace bondem
