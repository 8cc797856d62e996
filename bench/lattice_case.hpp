#pragma once
// The benchmarks' dense case, the peers' kind (shared/peers): 1 mm spheres on a simple-cubic
// lattice of 1.999 mm (neighbors slightly overlapped), periodic in x and y, a floor, gravity,
// E = 1 GPa, nu = 0.3, restitution 0.5 (xi_con = 0.197), optionally sliding friction 0.5.
#include "solver/engine/scene.hpp"
#include "solver/setup/insertion.hpp"

namespace bondem::bench {

/// The lattice's floor: an analytic plane, or the same plane as a triangle mesh.
enum class Floor { kPlane, kMesh };

/// Triangles of the mesh floor: 2 x 224^2 = 100 352, the 100 000-triangle target.
inline constexpr int kMeshFloorCells = 224;

/// side x side x layers spheres.
inline Scene lattice_scene(int side, int layers, bool friction, Floor floor = Floor::kPlane) {
  Case c;
  c.source = "bench";
  c.materials.push_back({"powder", 2000.0, 1.0e9, 0.3});
  c.contact.damping_ratio = 0.197;
  c.contact.friction = friction ? 0.5 : 0.0;
  c.contact.bond.criterion = BondCriterion::kNever;
  c.contact.bond.equilibrium_overlap = 1e-6;
  c.time_step = 5e-7;
  c.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  const double spacing = 0.001999;
  const double length = side * spacing;
  const Box region{Eigen::Vector3d::Zero(),
                   Eigen::Vector3d(length, length, layers * spacing + 1e-6)};
  c.particles = insert_lattice(region, spacing, 1e-3, 0);
  Domain d;
  d.max = Eigen::Vector3d(length, length, 2.0 * layers * spacing);
  d.periodic = {true, true, false};
  c.domain = d;
  if (floor == Floor::kPlane) {
    c.boundaries.push_back(
        plane_boundary(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), 0, "floor"));
  } else {
    // Past the periodic box by 5 % on each side: no sphere meets the mesh's rim.
    c.boundaries.push_back(
        mesh_boundary(tessellated_square(-0.05 * length, 1.05 * length, kMeshFloorCells),
                      Eigen::Vector3d::Zero(), 0, "floor"));
  }
  c.skin = 1e-4;
  return build_scene(c);
}

}  // namespace bondem::bench
