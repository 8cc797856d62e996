#pragma once
/// @file vtk_module.hpp
/// VTK's STL reader lives in a module of its own, libbondem_vtk.so, loaded the first time a run
/// reads an STL file: the VTK libraries it needs (vtkIOGeometry and, through it, VTK's rendering
/// and image readers: 24 more shared libraries) cost every start of bondem about 16 ms to load
/// and relocate, 1 % of a 2 000-step run of the 20 800 peer lattice. The module exports one
/// function with C linkage, bondem_read_stl_geometry (signature StlGeometryReader).

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace bondem {

/// What vtkSTLReader gives for a file: the points, coincident ones merged, and each polygon as
/// the ids of its points (a polygon that is not a triangle has an empty id list).
struct StlGeometry {
  std::vector<Eigen::Vector3d> points;
  std::vector<std::vector<std::int64_t>> polygons;
  std::string error;  ///< VTK's first error message, or empty
};

/// The module's function: reads @p path with vtkSTLReader (merging on) into @p out.
using StlGeometryReader = void (*)(const char* path, StlGeometry* out);

/// The module's name, as dlopen finds it.
inline constexpr const char* kVtkModuleName = "libbondem_vtk.so";

/// The module's STL reader, loading the module on first use: from $BONDEM_VTK_MODULE when set,
/// else beside the running executable, else from where the build or the installation put it,
/// else wherever dlopen finds kVtkModuleName. Throws std::runtime_error naming the places tried.
StlGeometryReader stl_geometry_reader();

}  // namespace bondem
