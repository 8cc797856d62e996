#pragma once
/// @file walls.hpp
/// Static walls: planes with an inward unit normal. A box container is six such planes.

#include <Eigen/Core>
#include <string>
#include <vector>

namespace bondem {

/// An infinite plane; particles live on the side the normal points to.
struct PlaneWall {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< unit, into the domain
  int material = 0;                                   ///< index into the case's materials
  std::string name;                                   ///< for reports, e.g. "box.z_min"
  double temperature = 0.0;  ///< held temperature [K] for heat exchange; 0: adiabatic
};

/// Signed distance of point (x, y, z) from the wall, positive on the particle side.
inline double distance_to(const PlaneWall& wall, double x, double y, double z) {
  return (x - wall.point.x()) * wall.normal.x() + (y - wall.point.y()) * wall.normal.y() +
         (z - wall.point.z()) * wall.normal.z();
}

/// Faces of an axis-aligned box, in the order x_min, x_max, y_min, y_max, z_min, z_max.
inline constexpr const char* kBoxFaceNames[6] = {"x_min", "x_max", "y_min",
                                                 "y_max", "z_min", "z_max"};

/// The inward-facing planes of box [min, max]; faces whose flag in @p open is set are left out.
inline std::vector<PlaneWall> box_walls(const Eigen::Vector3d& min, const Eigen::Vector3d& max,
                                        int material, const bool open[6],
                                        const std::string& name = "box") {
  std::vector<PlaneWall> walls;
  for (int face = 0; face < 6; ++face) {
    if (open[face]) continue;
    const int axis = face / 2;
    const bool upper = face % 2 == 1;
    PlaneWall wall;
    wall.point = upper ? max : min;
    wall.normal = Eigen::Vector3d::Zero();
    wall.normal[axis] = upper ? -1.0 : 1.0;
    wall.material = material;
    wall.name = name + "." + kBoxFaceNames[face];
    walls.push_back(wall);
  }
  return walls;
}

}  // namespace bondem
