#pragma once
/// @file vtk_module.hpp
/// Everything bondem does with VTK (the VTK series writer, read_vtp, the STL reader) lives in a
/// module of its own, libbondem_vtk.so, loaded the first time a run writes VTK output, reads an
/// STL file or reads a .vtp file back: VTK's libraries (40 shared libraries with the STL
/// reader's) cost every start of bondem about 30 ms to load and relocate, 1.5 % of a 2 000-step
/// run of the 20 800 peer lattice, which writes no VTK. The module exports functions with C
/// linkage, found by name: bondem_vtk_new_series, bondem_vtk_read_vtp,
/// bondem_vtk_particle_array_names (vtk_series.cpp) and bondem_read_stl_geometry.

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace bondem {

/// What vtkSTLReader gives for a file: the points, coincident ones merged, and each polygon as
/// the ids of its points (read_stl keeps the triangles).
struct StlGeometry {
  std::vector<Eigen::Vector3d> points;
  std::vector<std::vector<std::int64_t>> polygons;
  std::string error;  ///< VTK's first error message, or empty
};

/// The module's function: reads @p path with vtkSTLReader (merging on) into @p out.
using StlGeometryReader = void (*)(const char* path, StlGeometry* out);

/// The module's name, as dlopen finds it.
inline constexpr const char* kVtkModuleName = "libbondem_vtk.so";

/// The module's function called @p name, loading the module on first use: from
/// $BONDEM_VTK_MODULE when set, else beside the running executable, else from where the build or
/// the installation put it, else wherever dlopen finds kVtkModuleName. Throws std::runtime_error
/// naming the places tried.
void* vtk_module_function(const char* name);

/// vtk_module_function as a pointer to the function type @p Function it has.
template <class Function>
Function vtk_module_function(const char* name) {
  return reinterpret_cast<Function>(vtk_module_function(name));
}

}  // namespace bondem
