#include "io/stl_reader.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <string>
#include <system_error>
#include <vector>

#include "io/vtk_module.hpp"

namespace bondem {
namespace {

[[noreturn]] void fail(const std::filesystem::path& path, const std::string& reason) {
  throw StlError(path.string() + ": " + reason);
}

// How many facets the file declares, or a StlError: VTK would print to the terminal and return an
// empty mesh for most of these, so the form is checked here first.
int count_facets(const std::filesystem::path& path) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) fail(path, "no such file");
  const std::uintmax_t size = std::filesystem::file_size(path, error);
  std::ifstream in(path, std::ios::binary);
  if (error || !in) fail(path, "cannot be opened");
  std::string bytes(static_cast<std::size_t>(size), '\0');
  if (!in.read(bytes.data(), static_cast<std::streamsize>(size))) fail(path, "cannot be read");
  if (bytes.empty()) fail(path, "empty file, not an STL mesh");
  // Binary: an 80-byte header, a 32-bit little-endian count, 50 bytes per facet. Checked first:
  // binary headers may begin with "solid" too.
  if (bytes.size() >= 84) {
    std::uint32_t count = 0;
    for (int k = 3; k >= 0; --k)
      count = (count << 8U) | static_cast<unsigned char>(bytes[80 + static_cast<std::size_t>(k)]);
    if (bytes.size() == 84 + 50 * static_cast<std::size_t>(count)) {
      if (count == 0) fail(path, "binary STL with no facets");
      return static_cast<int>(count);
    }
  }
  const auto start = std::find_if_not(bytes.begin(), bytes.end(), [](char c) {
    return std::isspace(static_cast<unsigned char>(c));
  });
  if (bytes.compare(static_cast<std::size_t>(start - bytes.begin()), 5, "solid") != 0)
    fail(path,
         "not an STL file (neither \"solid\" text nor a binary facet count matching its size)");
  int count = 0;
  for (std::size_t at = bytes.find("endfacet"); at != std::string::npos;
       at = bytes.find("endfacet", at + 8))
    ++count;
  if (count == 0) fail(path, "ASCII STL with no facets");
  return count;
}

}  // namespace

StlMesh read_stl(const std::filesystem::path& path, double scale, const Eigen::Vector3d& offset) {
  if (!(scale > 0.0) || !std::isfinite(scale)) fail(path, "scale must be a positive number");
  StlMesh result;
  result.facets_in_file = count_facets(path);

  StlGeometry geometry;
  vtk_module_function<StlGeometryReader>("bondem_read_stl_geometry")(path.string().c_str(),
                                                                     &geometry);
  if (!geometry.error.empty()) {
    // VTK's message ends with a newline and may carry the source location; keep the first line.
    fail(path,
         "not a readable STL file (" + geometry.error.substr(0, geometry.error.find('\n')) + ")");
  }
  TriangleMesh& mesh = result.mesh;
  mesh.vertices.reserve(geometry.points.size());
  for (const Eigen::Vector3d& x : geometry.points) mesh.vertices.emplace_back(scale * x + offset);
  for (const std::vector<std::int64_t>& ids : geometry.polygons) {
    if (ids.size() != 3) continue;  // counted as dropped below
    const std::array<int, 3> tri{static_cast<int>(ids[0]), static_cast<int>(ids[1]),
                                 static_cast<int>(ids[2])};
    const Eigen::Vector3d& a = mesh.vertices[tri[0]];
    const Eigen::Vector3d& b = mesh.vertices[tri[1]];
    const Eigen::Vector3d& d = mesh.vertices[tri[2]];
    const double longest2 =
        std::max({(b - a).squaredNorm(), (d - b).squaredNorm(), (a - d).squaredNorm()});
    if (!((b - a).cross(d - a).norm() > kDegenerateFacet * longest2)) continue;
    mesh.triangles.push_back(tri);
  }
  // VTK itself leaves out facets whose merged corners repeat: all facets missing here were
  // degenerate (or, never seen, not triangles).
  result.dropped_degenerate = result.facets_in_file - static_cast<int>(mesh.triangles.size());
  if (mesh.triangles.empty())
    fail(path, "no facet with a non-zero area (" + std::to_string(result.facets_in_file) +
                   " degenerate)");
  // Vertices of dropped facets only are kept: indices stay those of VTK, and an unused vertex
  // touches nothing.
  compute_normals(mesh);
  return result;
}

}  // namespace bondem
