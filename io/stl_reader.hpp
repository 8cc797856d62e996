#pragma once
/// @file stl_reader.hpp
/// Triangle meshes from STL files (ASCII or binary), through VTK's vtkSTLReader (in the module
/// libbondem_vtk.so, loaded on first use: vtk_module.hpp).

#include <Eigen/Core>
#include <filesystem>
#include <stdexcept>

#include "geometry/triangle_mesh.hpp"

namespace bondem {

/// A file that is not a usable STL mesh; the message starts with the file's path.
class StlError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A mesh read from STL, with what reading it dropped.
struct StlMesh {
  TriangleMesh mesh;           ///< coincident vertices merged, normals from the winding
  int facets_in_file = 0;      ///< facets the file declares
  int dropped_degenerate = 0;  ///< zero-area facets left out (see read_stl)
};

/// Relative area below which a facet counts as zero-area: |(v1 - v0) x (v2 - v0)| below this times
/// the square of its longest edge, i.e. a smallest angle under about 1e-10 rad, whose normal is
/// round-off.
inline constexpr double kDegenerateFacet = 1.0e-10;

/// Read @p path (ASCII or binary STL), map every vertex x to scale * x + offset, merge coincident
/// vertices and compute the normals from the winding (the file's normals are ignored). Zero-area
/// facets (two corners merged into one, or collinear corners) are dropped and counted: CAD
/// exporters write such slivers, they carry no surface, and their edges are edges of their
/// neighbours. Throws StlError naming the file for a missing or unreadable file, an empty file, a
/// file that is neither ASCII nor binary STL, and a file with no facet left; and for a scale that
/// is not positive (a negative one would mirror the part).
StlMesh read_stl(const std::filesystem::path& path, double scale = 1.0,
                 const Eigen::Vector3d& offset = Eigen::Vector3d::Zero());

}  // namespace bondem
