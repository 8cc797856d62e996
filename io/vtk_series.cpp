// The module libbondem_vtk.so (vtk_module.hpp): the VTK series writer (vtk_series.hpp) and
// read_vtp with VTK's own XML writers and readers.
#include "io/vtk_series.hpp"

#include <unistd.h>
#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkCommand.h>
#include <vtkDataArray.h>
#include <vtkDataSetAttributes.h>
#include <vtkDoubleArray.h>
#include <vtkErrorCode.h>
#include <vtkExecutive.h>
#include <vtkFieldData.h>
#include <vtkIdList.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkSmartPointer.h>
#include <vtkStringArray.h>
#include <vtkTypeInt32Array.h>
#include <vtkTypeInt64Array.h>
#include <vtkTypeUInt8Array.h>
#include <vtkXMLPPolyDataReader.h>
#include <vtkXMLPolyDataReader.h>
#include <vtkXMLPolyDataWriter.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <regex>
#include <set>
#include <stdexcept>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <utility>
#include <variant>

#include "io/atomic_file.hpp"

namespace bondem {
namespace {

namespace fs = std::filesystem;

/// Receives the errors VTK would print to stderr, so that they end up in the exception instead.
class ErrorCollector : public vtkCommand {
 public:
  static ErrorCollector* New() { return new ErrorCollector; }

  void Execute(vtkObject*, unsigned long, void* call_data) override {
    // Keep the first message: later ones are usually consequences of it.
    if (!message.empty()) return;
    std::string text = call_data != nullptr ? static_cast<const char*>(call_data) : "VTK error";
    // Drop the "ERROR: In file, line N" and "vtkClass (0x...): " decoration.
    if (const std::size_t start = text.find("): "); start != std::string::npos) {
      text.erase(0, start + 3);
    }
    std::replace(text.begin(), text.end(), '\n', ' ');
    while (!text.empty() && text.back() == ' ') text.pop_back();
    message = text.empty() ? "VTK error" : text;
  }

  std::string message;
};

/// A temporary file that is removed unless released: no exception path leaves one behind.
class TemporaryFile {
 public:
  explicit TemporaryFile(const std::string& final_path)
      : path_(final_path + ".tmp." + std::to_string(::getpid())) {}
  ~TemporaryFile() {
    if (!released_) {
      std::error_code ignored;
      fs::remove(path_, ignored);
    }
  }
  TemporaryFile(const TemporaryFile&) = delete;
  TemporaryFile& operator=(const TemporaryFile&) = delete;

  const std::string& path() const { return path_; }
  void release() { released_ = true; }

 private:
  std::string path_;
  bool released_ = false;
};

/// Write @p data to @p path as binary appended, zlib-compressed XML PolyData, atomically.
void write_vtp(vtkPolyData* data, const std::string& path) {
  TemporaryFile temporary(path);
  vtkNew<ErrorCollector> errors;
  vtkNew<vtkXMLPolyDataWriter> writer;
  writer->AddObserver(vtkCommand::ErrorEvent, errors);
  // The pipeline reports the writer's failure once more, from its executive.
  writer->GetExecutive()->AddObserver(vtkCommand::ErrorEvent, errors);
  writer->SetInputData(data);
  writer->SetDataModeToAppended();
  writer->EncodeAppendedDataOff();  // raw bytes: base64 would cost a third more
  writer->SetCompressorTypeToZLib();
  writer->SetHeaderTypeToUInt64();  // block sizes of arrays above 4 GiB still fit
  writer->SetFileName(temporary.path().c_str());
  const int written = writer->Write();
  if (written != 1 || writer->GetErrorCode() != vtkErrorCode::NoError || !errors->message.empty()) {
    throw std::runtime_error(path + ": cannot write VTK file" +
                             (errors->message.empty() ? "" : ": " + errors->message));
  }
  std::error_code error;
  fs::rename(temporary.path(), path, error);
  if (error) throw std::runtime_error(path + ": cannot move into place: " + error.message());
  temporary.release();
}

/// Shortest text that reads back as the same double, so .pvd times are exact.
std::string format_time(double time) {
  std::array<char, 32> buffer{};
  const std::to_chars_result result =
      std::to_chars(buffer.data(), buffer.data() + buffer.size(), time);
  return std::string(buffer.data(), result.ptr);
}

/// "<series>_NNNNNN.vtp" for frame @p index.
std::string frame_file(const char* series, std::size_t index) {
  std::array<char, 64> buffer{};
  std::snprintf(buffer.data(), buffer.size(), "%s_%06zu.vtp", series, index);
  return buffer.data();
}

/// "<series>_NNNNNN_<piece>.vtp": piece @p piece of frame @p index.
std::string piece_file(const char* series, std::size_t index, int piece) {
  std::array<char, 80> buffer{};
  std::snprintf(buffer.data(), buffer.size(), "%s_%06zu_%d.vtp", series, index, piece);
  return buffer.data();
}

/// "<series>_NNNNNN.pvtp": the summary of frame @p index's pieces.
std::string summary_file(const char* series, std::size_t index) {
  std::array<char, 64> buffer{};
  std::snprintf(buffer.data(), buffer.size(), "%s_%06zu.pvtp", series, index);
  return buffer.data();
}

/// VTK XML name of the value type of @p array ("Float64", "Int32", "UInt8", ...).
std::string xml_type_name(vtkDataArray* array);

/// The PDataArray elements that declare the arrays of @p attributes.
void declare_arrays(std::ostream& out, vtkDataSetAttributes* attributes, const char* indent) {
  for (int k = 0; k < attributes->GetNumberOfArrays(); ++k) {
    vtkDataArray* array = attributes->GetArray(k);
    out << indent << "<PDataArray type=\"" << xml_type_name(array) << "\" Name=\""
        << array->GetName() << "\" NumberOfComponents=\"" << array->GetNumberOfComponents()
        << "\"/>\n";
  }
}

/// Writes, atomically, the .pvtp summary @p path of the pieces @p pieces (file names relative to
/// it), whose arrays are those of @p piece (every piece has the same arrays): what a parallel
/// reader needs to open them as one data set. The summary carries no data of its own, so it is
/// written as text here rather than by a VTK writer that would also write a piece.
void write_summary(const std::string& path, vtkPolyData* piece,
                   const std::vector<std::string>& pieces) {
  AtomicFile file(path);
  std::ostream& out = file.stream();
  out << "<?xml version=\"1.0\"?>\n<VTKFile type=\"PPolyData\" version=\"1.0\" byte_order=\""
      << (std::endian::native == std::endian::little ? "LittleEndian" : "BigEndian")
      << "\" header_type=\"UInt64\">\n  <PPolyData GhostLevel=\"0\">\n";
  out << "    <PPointData>\n";
  declare_arrays(out, piece->GetPointData(), "      ");
  out << "    </PPointData>\n    <PCellData>\n";
  declare_arrays(out, piece->GetCellData(), "      ");
  out << "    </PCellData>\n    <PPoints>\n      <PDataArray type=\""
      << xml_type_name(piece->GetPoints()->GetData())
      << "\" Name=\"Points\" NumberOfComponents=\"3\"/>\n    </PPoints>\n";
  for (const std::string& source : pieces) out << "    <Piece Source=\"" << source << "\"/>\n";
  out << "  </PPolyData>\n</VTKFile>\n";
  file.commit();
}

vtkIdType vtk_size(std::size_t n) {
  return static_cast<vtkIdType>(n);
}

/// Index of tuple @p k: order[k], or k itself without an order.
std::size_t source_index(const std::vector<std::uint32_t>* order, std::size_t k) {
  return order != nullptr ? (*order)[k] : k;
}

/// A one-component Float64 array holding @p values (a vector of doubles, of any allocator), in
/// @p order when given (particle arrays: by id).
template <class Values>
vtkSmartPointer<vtkDoubleArray> scalar_array(const std::string& name, const Values& values,
                                             const std::vector<std::uint32_t>* order = nullptr) {
  auto array = vtkSmartPointer<vtkDoubleArray>::New();
  array->SetName(name.c_str());
  array->SetNumberOfComponents(1);
  array->SetNumberOfTuples(vtk_size(values.size()));
  for (std::size_t k = 0; k < values.size(); ++k) {
    array->SetValue(vtk_size(k), values[source_index(order, k)]);
  }
  return array;
}

/// A three-component Float64 array interleaving the SoA components @p x, @p y, @p z (vectors of
/// doubles, of any allocator), in @p order when given.
template <class Values>
vtkSmartPointer<vtkDoubleArray> vector_array(const std::string& name, const Values& x,
                                             const Values& y, const Values& z,
                                             const std::vector<std::uint32_t>* order = nullptr) {
  auto array = vtkSmartPointer<vtkDoubleArray>::New();
  array->SetName(name.c_str());
  array->SetNumberOfComponents(3);
  array->SetNumberOfTuples(vtk_size(x.size()));
  for (std::size_t k = 0; k < x.size(); ++k) {
    const std::size_t i = source_index(order, k);
    const double tuple[3] = {x[i], y[i], z[i]};
    array->SetTypedTuple(vtk_size(k), tuple);
  }
  return array;
}

/// A one-component integer array of VTK type @p Array filled by @p value(i) for i < @p n.
template <class Array, class Value>
vtkSmartPointer<Array> integer_array(const char* name, std::size_t n, Value value) {
  auto array = vtkSmartPointer<Array>::New();
  array->SetName(name);
  array->SetNumberOfComponents(1);
  array->SetNumberOfTuples(vtk_size(n));
  for (std::size_t i = 0; i < n; ++i) {
    array->SetValue(vtk_size(i), static_cast<typename Array::ValueType>(value(i)));
  }
  return array;
}

/// Float64 points, so that positions read back bit for bit.
vtkNew<vtkPoints> make_points(std::size_t n) {
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(vtk_size(n));
  return points;
}

/// One point array of the particle file that comes from kParticleFields: a scalar row, or the
/// three rows of a vector.
struct TableArray {
  std::string_view name;
  int order = 0;
  const ParticleField* rows[3] = {nullptr, nullptr, nullptr};  ///< the scalar's row in [0]
  bool vector = false;
};

/// The table's arrays that @p p has (thermal ones only when temperatures are tracked), in
/// ascending VTK order.
std::vector<TableArray> table_arrays(const Particles& p) {
  std::vector<TableArray> arrays;
  for (const ParticleField& field : kParticleFields) {
    if (field.vtk_name.empty() || field.vtk_component > 0 || !in_use(field, p)) continue;
    TableArray array{
        field.vtk_name, field.vtk_order, {&field, nullptr, nullptr}, field.vtk_component == 0};
    if (array.vector) {
      for (const ParticleField& other : kParticleFields) {
        if (other.vtk_name == field.vtk_name && other.vtk_component > 0) {
          array.rows[other.vtk_component] = &other;
        }
      }
    }
    arrays.push_back(array);
  }
  std::stable_sort(arrays.begin(), arrays.end(),
                   [](const TableArray& a, const TableArray& b) { return a.order < b.order; });
  return arrays;
}

/// The doubles of row @p field of @p p (vector components are doubles: particle_fields_consistent).
const StaggeredVector<double>& doubles(const Particles& p, const ParticleField& field) {
  return p.*std::get<StaggeredVector<double> Particles::*>(field.member);
}

/// The VTK array of table array @p array: Int64, Int32 or Float64 as the member's type, the
/// particles in @p order.
vtkSmartPointer<vtkDataArray> make_table_array(const Particles& p, const TableArray& array,
                                               const std::vector<std::uint32_t>& order) {
  const std::string name(array.name);
  if (array.vector) {
    return vector_array(name, doubles(p, *array.rows[0]), doubles(p, *array.rows[1]),
                        doubles(p, *array.rows[2]), &order);
  }
  return std::visit(
      [&](auto member) -> vtkSmartPointer<vtkDataArray> {
        const auto& values = p.*member;
        using Value = typename std::remove_reference_t<decltype(values)>::value_type;
        const auto value = [&](std::size_t k) { return values[order[k]]; };
        if constexpr (std::is_same_v<Value, std::int64_t>) {
          return integer_array<vtkTypeInt64Array>(name.c_str(), values.size(), value);
        } else if constexpr (std::is_same_v<Value, std::int32_t>) {
          return integer_array<vtkTypeInt32Array>(name.c_str(), values.size(), value);
        } else {
          return scalar_array(name, values, &order);
        }
      },
      array.rows[0]->member);
}

vtkSmartPointer<vtkPolyData> particle_data(const Particles& p,
                                           const std::vector<VtkSeriesWriter::ScalarField>& scalars,
                                           const std::vector<VtkSeriesWriter::VectorField>& vectors,
                                           const std::vector<std::string>& selected) {
  const auto wanted = [&](std::string_view name) {
    return selected.empty() || std::find(selected.begin(), selected.end(), name) != selected.end();
  };
  const std::size_t n = p.size();
  // Points by id: a frame does not depend on how the run stores the particles.
  const std::vector<std::uint32_t> by_id = p.order_by_id();
  vtkNew<vtkPoints> points = make_points(n);
  // One vertex cell per particle: ParaView's Points and Surface representations draw only cells.
  vtkNew<vtkCellArray> verts;
  verts->AllocateExact(vtk_size(n), vtk_size(n));
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint32_t i = by_id[k];
    points->SetPoint(vtk_size(k), p.x[i], p.y[i], p.z[i]);
    const vtkIdType point = vtk_size(k);
    verts->InsertNextCell(1, &point);
  }
  auto data = vtkSmartPointer<vtkPolyData>::New();
  data->SetPoints(points);
  data->SetVerts(verts);
  vtkPointData* arrays = data->GetPointData();
  // The table's arrays by their order, the caller's derived scalars and vectors at their places.
  const std::vector<TableArray> table = table_arrays(p);
  auto next = table.begin();
  const auto add_table_until = [&](int order) {
    for (; next != table.end() && next->order < order; ++next) {
      if (wanted(next->name)) arrays->AddArray(make_table_array(p, *next, by_id));
    }
  };
  add_table_until(kVtkDerivedScalarsOrder);
  for (const VtkSeriesWriter::ScalarField& field : scalars) {
    if (wanted(field.name)) arrays->AddArray(scalar_array(field.name, *field.values, &by_id));
  }
  add_table_until(kVtkDerivedVectorsOrder);
  for (const VtkSeriesWriter::VectorField& field : vectors) {
    if (wanted(field.name))
      arrays->AddArray(vector_array(field.name, *field.x, *field.y, *field.z, &by_id));
  }
  add_table_until(std::numeric_limits<int>::max());
  return data;
}

/// Field data "TimeValue" (ParaView's name for a dataset's time): one double.
void add_time_value(vtkPolyData* data, double time) {
  vtkNew<vtkDoubleArray> value;
  value->SetName("TimeValue");
  value->SetNumberOfTuples(1);
  value->SetValue(0, time);
  data->GetFieldData()->AddArray(value);
}

/// A string field-data array called @p name.
void add_strings(vtkPolyData* data, const char* name, const std::vector<std::string>& values) {
  vtkNew<vtkStringArray> array;
  array->SetName(name);
  array->SetNumberOfValues(vtk_size(values.size()));
  for (std::size_t k = 0; k < values.size(); ++k) array->SetValue(vtk_size(k), values[k]);
  data->GetFieldData()->AddArray(array);
}

/// Lines of @p contacts, or of the bonded ones only when @p bonded_only.
/// The 12 edges of the domain box, as lines (its faces would hide the particles).
vtkSmartPointer<vtkPolyData> domain_data(const Domain& domain) {
  vtkNew<vtkPoints> points = make_points(8);
  for (int corner = 0; corner < 8; ++corner) {
    const double x[3] = {(corner & 1) != 0 ? domain.max.x() : domain.min.x(),
                         (corner & 2) != 0 ? domain.max.y() : domain.min.y(),
                         (corner & 4) != 0 ? domain.max.z() : domain.min.z()};
    points->SetPoint(corner, x);
  }
  vtkNew<vtkCellArray> edges;
  for (int corner = 0; corner < 8; ++corner) {
    for (const int bit : {1, 2, 4}) {
      if ((corner & bit) != 0) continue;
      const vtkIdType ends[2] = {corner, corner | bit};
      edges->InsertNextCell(2, ends);
    }
  }
  auto data = vtkSmartPointer<vtkPolyData>::New();
  data->SetPoints(points);
  data->SetLines(edges);
  return data;
}

vtkSmartPointer<vtkPolyData> contact_data(const std::vector<ContactRecord>& all,
                                          bool bonded_only = false) {
  std::vector<const ContactRecord*> chosen;
  for (const ContactRecord& c : all) {
    if (!bonded_only || c.bonded) chosen.push_back(&c);
  }
  const std::size_t m = chosen.size();
  const auto contact = [&](std::size_t k) -> const ContactRecord& { return *chosen[k]; };
  vtkNew<vtkPoints> points = make_points(2 * m);
  vtkNew<vtkCellArray> lines;
  lines->AllocateExact(vtk_size(m), vtk_size(2 * m));
  std::vector<double> overlap(m), normal_force(m);
  // The force on j split along the line from i to j (normal) and across it (tangential).
  StaggeredVector<double> nx(m), ny(m), nz(m), tx(m), ty(m), tz(m);
  for (std::size_t k = 0; k < m; ++k) {
    const ContactRecord& c = contact(k);
    const vtkIdType ends[2] = {vtk_size(2 * k), vtk_size(2 * k + 1)};
    points->SetPoint(ends[0], c.first_position.data());
    points->SetPoint(ends[1], c.second_position.data());
    lines->InsertNextCell(2, ends);
    overlap[k] = c.overlap;
    normal_force[k] = c.normal_force;
    const Eigen::Vector3d n = (c.second_position - c.first_position).normalized();
    const Eigen::Vector3d normal = c.force.dot(n) * n;
    const Eigen::Vector3d tangential = c.force - normal;
    nx[k] = normal.x();
    ny[k] = normal.y();
    nz[k] = normal.z();
    tx[k] = tangential.x();
    ty[k] = tangential.y();
    tz[k] = tangential.z();
  }
  auto data = vtkSmartPointer<vtkPolyData>::New();
  data->SetPoints(points);
  data->SetLines(lines);
  vtkCellData* arrays = data->GetCellData();
  arrays->AddArray(scalar_array("overlap", overlap));
  arrays->AddArray(scalar_array("normal_force", normal_force));
  arrays->AddArray(integer_array<vtkTypeUInt8Array>(
      "bonded", m, [&](std::size_t k) { return contact(k).bonded ? 1 : 0; }));
  arrays->AddArray(
      integer_array<vtkTypeInt64Array>("id_i", m, [&](std::size_t k) { return contact(k).id_i; }));
  arrays->AddArray(
      integer_array<vtkTypeInt64Array>("id_j", m, [&](std::size_t k) { return contact(k).id_j; }));
  arrays->AddArray(vector_array("normal_force_vector", nx, ny, nz));
  arrays->AddArray(vector_array("tangential_force_vector", tx, ty, tz));
  return data;
}

using Polygon = std::vector<Eigen::Vector3d>;

/// Sutherland-Hodgman step: the part of @p polygon where side * (p[axis] - bound) >= 0.
Polygon clip(const Polygon& polygon, int axis, double bound, double side) {
  Polygon kept;
  for (std::size_t k = 0; k < polygon.size(); ++k) {
    const Eigen::Vector3d& a = polygon[k];
    const Eigen::Vector3d& b = polygon[(k + 1) % polygon.size()];
    const double da = side * (a[axis] - bound);
    const double db = side * (b[axis] - bound);
    if (da >= 0.0) kept.push_back(a);
    // Strict signs: a vertex lying on the bound is kept once, not again as an intersection.
    if ((da > 0.0 && db < 0.0) || (da < 0.0 && db > 0.0)) {
      Eigen::Vector3d crossing = a + (da / (da - db)) * (b - a);
      crossing[axis] = bound;  // exactly on the face despite rounding
      kept.push_back(crossing);
    }
  }
  return kept;
}

/// Outline of @p wall: a square of side @p side centred at the foot of the domain centre,
/// counter-clockwise about the wall normal, clipped to the domain box.
Polygon wall_polygon(const PlaneWall& wall, const Domain& domain, double side) {
  const Eigen::Vector3d n = wall.normal.normalized();
  const Eigen::Vector3d centre = 0.5 * (domain.min + domain.max);
  Eigen::Vector3d foot = centre - (centre - wall.point).dot(n) * n;
  // A plane perpendicular to an axis is wholly inside or wholly outside that axis' slab, so the
  // slab does not clip it; its coordinate is the wall's own, exactly.
  std::array<bool, 3> perpendicular{};
  for (int axis = 0; axis < 3; ++axis) {
    perpendicular[static_cast<std::size_t>(axis)] = std::abs(n[axis]) >= 1.0 - 1e-12;
    if (perpendicular[static_cast<std::size_t>(axis)]) foot[axis] = wall.point[axis];
  }
  // In-plane basis from the axis least aligned with n; for an axis-aligned normal, u and v are
  // exactly axis-aligned, so a box face comes out as the exact face rectangle.
  Eigen::Index least = 0;
  n.cwiseAbs().minCoeff(&least);
  const Eigen::Vector3d u = n.cross(Eigen::Vector3d::Unit(least)).normalized();
  const Eigen::Vector3d v = n.cross(u);
  const double half = 0.5 * side;
  Polygon square{foot - half * u - half * v, foot + half * u - half * v, foot + half * u + half * v,
                 foot - half * u + half * v};
  if (!(domain.length().array() > 0.0).all()) return square;
  Polygon clipped = square;
  for (int axis = 0; axis < 3 && clipped.size() >= 3; ++axis) {
    if (perpendicular[static_cast<std::size_t>(axis)]) continue;
    clipped = clip(clipped, axis, domain.min[axis], 1.0);
    clipped = clip(clipped, axis, domain.max[axis], -1.0);
  }
  // A plane that misses the box is still drawn, unclipped, rather than silently dropped.
  return clipped.size() >= 3 ? clipped : square;
}

vtkSmartPointer<vtkPolyData> wall_data(const std::vector<PlaneWall>& walls, const Domain& domain,
                                       double side) {
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  vtkNew<vtkCellArray> polys;
  for (const PlaneWall& wall : walls) {
    const Polygon outline = wall_polygon(wall, domain, side);
    std::vector<vtkIdType> ids;
    for (const Eigen::Vector3d& corner : outline)
      ids.push_back(points->InsertNextPoint(corner.data()));
    polys->InsertNextCell(vtk_size(ids.size()), ids.data());
  }
  auto data = vtkSmartPointer<vtkPolyData>::New();
  data->SetPoints(points);
  data->SetPolys(polys);
  vtkCellData* arrays = data->GetCellData();
  arrays->AddArray(integer_array<vtkTypeInt32Array>("wall_index", walls.size(),
                                                    [](std::size_t w) { return w; }));
  arrays->AddArray(integer_array<vtkTypeInt32Array>(
      "material", walls.size(), [&](std::size_t w) { return walls[w].material; }));
  return data;
}

/// Moving tools as the outlines their shapes give (a box as its six faces, a cylinder as a
/// 32-sided prism spanning the domain along its axis, ...). Cell arrays: tool index, material.
vtkSmartPointer<vtkPolyData> tool_data(const std::vector<const Boundary*>& bodies,
                                       const Domain& domain) {
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  vtkNew<vtkCellArray> polys;
  std::vector<int> tool_of_cell;
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    const Outline shape = outline(*bodies[b], domain);
    const vtkIdType first = points->GetNumberOfPoints();
    for (const Eigen::Vector3d& point : shape.points) points->InsertNextPoint(point.data());
    for (const std::vector<int>& polygon : shape.polygons) {
      std::vector<vtkIdType> ids;
      ids.reserve(polygon.size());
      for (const int corner : polygon) ids.push_back(first + corner);
      polys->InsertNextCell(vtk_size(ids.size()), ids.data());
      tool_of_cell.push_back(static_cast<int>(b));
    }
  }
  auto data = vtkSmartPointer<vtkPolyData>::New();
  data->SetPoints(points);
  data->SetPolys(polys);
  vtkCellData* arrays = data->GetCellData();
  arrays->AddArray(integer_array<vtkTypeInt32Array>(
      "tool_index", tool_of_cell.size(), [&](std::size_t c) { return tool_of_cell[c]; }));
  arrays->AddArray(integer_array<vtkTypeInt32Array>(
      "material", tool_of_cell.size(),
      [&](std::size_t c) { return bodies[static_cast<std::size_t>(tool_of_cell[c])]->material; }));
  return data;
}

void check_inputs(const Particles& p, const std::vector<PlaneWall>& walls,
                  const std::vector<VtkSeriesWriter::ScalarField>& scalars,
                  const std::vector<VtkSeriesWriter::VectorField>& vectors) {
  const std::size_t n = p.size();
  const std::vector<TableArray> table = table_arrays(p);
  bool sizes_agree = p.x.size() == n && p.y.size() == n && p.z.size() == n;
  for (const TableArray& array : table) {
    for (const ParticleField* row : array.rows) {
      if (row != nullptr) {
        std::visit([&](auto member) { sizes_agree = sizes_agree && (p.*member).size() == n; },
                   row->member);
      }
    }
  }
  if (!sizes_agree) throw std::invalid_argument("VTK output: particle arrays differ in size");
  // Duplicate names would make ParaView show only one of the arrays.
  std::set<std::string> names;
  for (const TableArray& array : table) names.emplace(array.name);
  const auto check_name = [&](const std::string& name) {
    if (name.empty()) throw std::invalid_argument("VTK output: extra field with an empty name");
    if (!names.insert(name).second) {
      throw std::invalid_argument("VTK output: field \"" + name + "\" is given twice");
    }
  };
  const auto check_values = [&](const std::string& name, const auto* values) {
    if (values == nullptr || values->size() != n) {
      throw std::invalid_argument("VTK output: field \"" + name + "\" needs " + std::to_string(n) +
                                  " values, one per particle");
    }
  };
  for (const VtkSeriesWriter::ScalarField& field : scalars) {
    check_name(field.name);
    check_values(field.name, field.values);
  }
  for (const VtkSeriesWriter::VectorField& field : vectors) {
    check_name(field.name);
    check_values(field.name, field.x);
    check_values(field.name, field.y);
    check_values(field.name, field.z);
  }
  for (std::size_t w = 0; w < walls.size(); ++w) {
    const PlaneWall& wall = walls[w];
    if (!wall.point.allFinite() || !wall.normal.allFinite() || !(wall.normal.norm() > 0.0)) {
      throw std::invalid_argument("VTK output: wall " + std::to_string(w) + " (" + wall.name +
                                  ") has no finite point and normal");
    }
  }
}

/// Write, atomically, the .pvd collection @p path listing @p files at @p times.
void write_collection(const std::string& path, const std::vector<double>& times,
                      const std::vector<std::string>& files) {
  AtomicFile out(path);
  std::ostream& s = out.stream();
  s << "<?xml version=\"1.0\"?>\n"
       "<VTKFile type=\"Collection\" version=\"0.1\">\n"
       "  <Collection>\n";
  for (std::size_t k = 0; k < times.size(); ++k) {
    s << "    <DataSet timestep=\"" << format_time(times[k]) << "\" part=\"0\" file=\"" << files[k]
      << "\"/>\n";
  }
  s << "  </Collection>\n"
       "</VTKFile>\n";
  out.commit();
}

/// VTK XML name of the value type of @p array ("Float64", "Int32", "UInt8", ...).
std::string xml_type_name(vtkDataArray* array) {
  const std::string bits = std::to_string(8 * array->GetDataTypeSize());
  switch (array->GetDataType()) {
    case VTK_FLOAT:
    case VTK_DOUBLE:
      return "Float" + bits;
    case VTK_UNSIGNED_CHAR:
    case VTK_UNSIGNED_SHORT:
    case VTK_UNSIGNED_INT:
    case VTK_UNSIGNED_LONG:
    case VTK_UNSIGNED_LONG_LONG:
      return "UInt" + bits;
    default:
      return "Int" + bits;
  }
}

std::vector<VtpArray> read_arrays(vtkDataSetAttributes* attributes) {
  std::vector<VtpArray> arrays;
  for (int a = 0; a < attributes->GetNumberOfArrays(); ++a) {
    vtkDataArray* data = attributes->GetArray(a);
    if (data == nullptr) continue;  // string arrays: not written here
    VtpArray array;
    array.name = data->GetName() != nullptr ? data->GetName() : "";
    array.type = xml_type_name(data);
    array.components = data->GetNumberOfComponents();
    const vtkIdType tuples = data->GetNumberOfTuples();
    array.values.reserve(static_cast<std::size_t>(tuples * array.components));
    for (vtkIdType t = 0; t < tuples; ++t) {
      for (int c = 0; c < array.components; ++c) array.values.push_back(data->GetComponent(t, c));
    }
    arrays.push_back(std::move(array));
  }
  return arrays;
}

}  // namespace

VtkSeries::VtkSeries(std::string directory) : directory_(std::move(directory)) {
  if (directory_.empty()) throw std::invalid_argument("VTK output: empty directory name");
  std::error_code error;
  fs::create_directories(directory_, error);
  if (error || !fs::is_directory(directory_)) {
    throw std::runtime_error(directory_ + ": cannot create VTK output directory" +
                             (error ? ": " + error.message() : ""));
  }
}

void VtkSeries::set_wall_extent(double side) {
  if (!(side >= 0.0) || !std::isfinite(side)) {
    throw std::invalid_argument("VTK output: wall extent must be finite and >= 0");
  }
  wall_extent_ = side;
}

bool VtkSeries::WallGeometry::same_as(const std::vector<PlaneWall>& other_walls,
                                      const Domain& other_domain, double other_extent) const {
  if (moving || extent != other_extent || domain.min != other_domain.min ||
      domain.max != other_domain.max || walls.size() != other_walls.size()) {
    return false;
  }
  for (std::size_t w = 0; w < walls.size(); ++w) {
    if (walls[w].point != other_walls[w].point || walls[w].normal != other_walls[w].normal ||
        walls[w].material != other_walls[w].material) {
      return false;
    }
  }
  return true;
}

std::vector<std::string> VtkSeries::particle_array_names(const Particles& particles,
                                                         const std::vector<std::string>& derived) {
  std::vector<std::string> names;
  for (const TableArray& array : table_arrays(particles)) names.emplace_back(array.name);
  for (const std::string& name : derived) {
    if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
  }
  return names;
}

void VtkSeries::write_frame(double time, const Particles& particles,
                            const std::vector<ContactRecord>& contacts,
                            const std::vector<Boundary>& boundaries, const Domain& domain,
                            const std::vector<ScalarField>& scalars,
                            const std::vector<VectorField>& vectors) {
  std::vector<PlaneWall> walls;
  std::vector<const Boundary*> bodies;
  bool moving = false;
  for (const Boundary& boundary : boundaries) {
    if (is_plane(boundary)) {
      walls.push_back(plane_of(boundary));
      moving = moving || boundary.motion.moves();
    } else {
      bodies.push_back(&boundary);
    }
  }
  if (!std::isfinite(time)) throw std::invalid_argument("VTK output: time is not finite");
  if (!times_.empty() && !(time > times_.back())) {
    throw std::invalid_argument("VTK output: frame time " + format_time(time) +
                                " is not after the previous frame's " + format_time(times_.back()));
  }
  check_inputs(particles, walls, scalars, vectors);
  const double side = wall_extent_ > 0.0 ? wall_extent_ : domain.length().norm();
  if (!walls.empty() && !(side > 0.0 && std::isfinite(side))) {
    throw std::invalid_argument(
        "VTK output: walls need a domain of positive size or a wall extent");
  }

  const std::size_t frame = times_.size();
  const fs::path dir(directory_);
  const vtkSmartPointer<vtkPolyData> points = particle_data(particles, scalars, vectors, selected_);
  add_time_value(points, time);
  if (!material_names_.empty()) add_strings(points, "material_names", material_names_);
  if (!loads_.empty()) {
    std::vector<std::string> names;
    StaggeredVector<double> f[3], m[3];
    for (const BoundaryLoadRecord& load : loads_) {
      names.push_back(load.name);
      for (int a = 0; a < 3; ++a) {
        f[a].push_back(load.force[a]);
        m[a].push_back(load.moment[a]);
      }
    }
    add_strings(points, "boundary_names", names);
    points->GetFieldData()->AddArray(vector_array("boundary_force", f[0], f[1], f[2]));
    points->GetFieldData()->AddArray(vector_array("boundary_moment", m[0], m[1], m[2]));
  }
  // A frame's own file, or this writer's piece of it and, from piece 0, the summary of all.
  const auto write_part = [&](vtkPolyData* data, const char* series) {
    if (pieces_ == 1) {
      write_vtp(data, (dir / frame_file(series, frame)).string());
      return;
    }
    write_vtp(data, (dir / piece_file(series, frame, piece_)).string());
    if (piece_ != 0) return;
    std::vector<std::string> sources;
    for (int piece = 0; piece < pieces_; ++piece)
      sources.push_back(piece_file(series, frame, piece));
    write_summary((dir / summary_file(series, frame)).string(), data, sources);
  };
  write_part(points, "particles");
  const vtkSmartPointer<vtkPolyData> lines = contact_data(contacts);
  add_time_value(lines, time);
  write_part(lines, "contacts");
  if (bonds_) {
    const vtkSmartPointer<vtkPolyData> bonds = contact_data(contacts, true);
    add_time_value(bonds, time);
    write_part(bonds, "bonds");
  }
  if (piece_ != 0) {
    // The geometry and the collections are piece 0's.
    times_.push_back(time);
    in_pieces_.push_back(true);
    return;
  }
  if (!bodies.empty()) {
    const vtkSmartPointer<vtkPolyData> tools = tool_data(bodies, domain);
    add_time_value(tools, time);
    write_vtp(tools, (dir / frame_file("tools", frame)).string());
    tools_ = true;
  }
  if (frame == 0 || !fs::exists(dir / "domain.vtp")) {
    write_vtp(domain_data(domain), (dir / "domain.vtp").string());
  }

  std::optional<WallGeometry> walls_before = last_walls_;
  std::string wall_file;
  if (last_walls_ && last_walls_->same_as(walls, domain, wall_extent_)) {
    wall_file = wall_files_.back();
  } else {
    wall_file = frame_file("walls", frame);
    write_vtp(wall_data(walls, domain, side), (dir / wall_file).string());
    last_walls_ = WallGeometry{walls, domain, wall_extent_, moving};
  }

  times_.push_back(time);
  in_pieces_.push_back(pieces_ > 1);
  wall_files_.push_back(wall_file);
  if (pieces_ > 1) return;  // listed by publish(), once every piece is written
  try {
    write_collections();
  } catch (...) {
    // Not listed, not counted: the next frame reuses this index and rewrites every collection.
    times_.pop_back();
    in_pieces_.pop_back();
    wall_files_.pop_back();
    last_walls_ = std::move(walls_before);
    throw;
  }
}

void VtkSeries::set_pieces(int piece, int pieces) {
  if (pieces < 1 || piece < 0 || piece >= pieces) {
    throw std::invalid_argument("VTK output: piece " + std::to_string(piece) + " of " +
                                std::to_string(pieces));
  }
  piece_ = piece;
  pieces_ = pieces;
}

void VtkSeries::publish() const {
  if (pieces_ > 1 && piece_ == 0) write_collections();
}

std::string VtkSeries::listed_file(const char* series, std::size_t frame) const {
  return in_pieces_[frame] ? summary_file(series, frame) : frame_file(series, frame);
}

void VtkSeries::resume(const std::function<bool(double)>& keep_frame,
                       const std::vector<Boundary>& boundaries, const Domain& domain) {
  std::vector<PlaneWall> walls;
  bool moving = false;
  for (const Boundary& boundary : boundaries) {
    if (!is_plane(boundary)) continue;
    walls.push_back(plane_of(boundary));
    moving = moving || boundary.motion.moves();
  }
  times_.clear();
  wall_files_.clear();
  last_walls_.reset();
  const fs::path dir(directory_);
  {
    std::ifstream in(dir / "walls.pvd");
    static const std::regex entry(R"re(<DataSet timestep="([^"]+)"[^>]*file="([^"]+)")re");
    for (std::string line; std::getline(in, line);) {
      std::smatch match;
      if (!std::regex_search(line, match, entry)) continue;
      const std::string text = match[1].str();
      double frame_time = 0.0;
      const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), frame_time);
      if (error != std::errc() || end != text.data() + text.size()) break;
      if (!keep_frame(frame_time) || (!times_.empty() && !(frame_time > times_.back()))) break;
      times_.push_back(frame_time);
      wall_files_.push_back(match[2].str());
    }
  }
  // A kept frame is in pieces when its summary is there (frame files are named by index).
  std::error_code error;
  in_pieces_.clear();
  for (std::size_t frame = 0; frame < times_.size(); ++frame) {
    in_pieces_.push_back(fs::exists(dir / summary_file("particles", frame), error));
  }
  // The others' pieces and the collections are piece 0's to trim: every writer only learns
  // which frames stay (piece 0 rewrites walls.pvd whole, so a read sees the same frames).
  if (piece_ != 0) return;
  // Frames are numbered in order and a wall file is named after the frame that first drew it, so
  // every file numbered at or after the first dropped frame belongs to dropped frames only.
  static const std::regex frame_name(
      "(particles|contacts|bonds|walls|tools)_([0-9]{6,12})(_[0-9]+\\.vtp|\\.vtp|\\.pvtp)");
  std::vector<fs::path> dropped;
  for (const fs::directory_entry& file : fs::directory_iterator(dir, error)) {
    std::smatch match;
    const std::string name = file.path().filename().string();
    if (std::regex_match(name, match, frame_name) && std::stoull(match[2].str()) >= times_.size()) {
      dropped.push_back(file.path());
    }
  }
  for (const fs::path& path : dropped) fs::remove(path, error);
  tools_ = fs::exists(dir / "tools.pvd", error);
  if (times_.empty()) {
    for (const char* name :
         {"particles.pvd", "contacts.pvd", "bonds.pvd", "walls.pvd", "tools.pvd", "domain.vtp"}) {
      fs::remove(dir / name, error);
    }
    tools_ = false;
    return;
  }
  last_walls_ = WallGeometry{walls, domain, wall_extent_, moving};
  write_collections();
}

void VtkSeries::write_collections() const {
  const fs::path dir(directory_);
  std::vector<std::string> particle_files, contact_files;
  for (std::size_t frame = 0; frame < times_.size(); ++frame) {
    particle_files.push_back(listed_file("particles", frame));
    contact_files.push_back(listed_file("contacts", frame));
  }
  write_collection((dir / "particles.pvd").string(), times_, particle_files);
  write_collection((dir / "contacts.pvd").string(), times_, contact_files);
  write_collection((dir / "walls.pvd").string(), times_, wall_files_);
  if (bonds_) {
    std::vector<std::string> bond_files;
    for (std::size_t frame = 0; frame < times_.size(); ++frame) {
      bond_files.push_back(listed_file("bonds", frame));
    }
    write_collection((dir / "bonds.pvd").string(), times_, bond_files);
  }
  if (tools_) {
    std::vector<std::string> tool_files;
    for (std::size_t frame = 0; frame < times_.size(); ++frame) {
      tool_files.push_back(frame_file("tools", frame));
    }
    write_collection((dir / "tools.pvd").string(), times_, tool_files);
  }
}

VtpContents read_vtp_file(const std::string& path) {
  vtkNew<ErrorCollector> errors;
  const bool summary = fs::path(path).extension() == ".pvtp";
  const vtkSmartPointer<vtkXMLReader> reader =
      summary ? vtkSmartPointer<vtkXMLReader>(vtkSmartPointer<vtkXMLPPolyDataReader>::New())
              : vtkSmartPointer<vtkXMLReader>(vtkSmartPointer<vtkXMLPolyDataReader>::New());
  reader->AddObserver(vtkCommand::ErrorEvent, errors);
  reader->GetExecutive()->AddObserver(vtkCommand::ErrorEvent, errors);
  if (!fs::is_regular_file(path) || reader->CanReadFile(path.c_str()) == 0) {
    throw std::runtime_error(path + ": not a readable VTK PolyData file");
  }
  reader->SetFileName(path.c_str());
  reader->Update();
  if (reader->GetErrorCode() != vtkErrorCode::NoError || !errors->message.empty()) {
    throw std::runtime_error(path + ": cannot read VTK file" +
                             (errors->message.empty() ? "" : ": " + errors->message));
  }
  vtkPolyData* data = vtkPolyData::SafeDownCast(reader->GetOutputDataObject(0));
  VtpContents contents;
  for (vtkIdType i = 0; i < data->GetNumberOfPoints(); ++i) {
    Eigen::Vector3d point;
    data->GetPoint(i, point.data());
    contents.points.push_back(point);
  }
  vtkNew<vtkIdList> ids;
  const auto read_cells = [&](vtkCellArray* cells) {
    for (vtkIdType c = 0; c < cells->GetNumberOfCells(); ++c) {
      cells->GetCellAtId(c, ids);
      std::vector<std::int64_t>& cell = contents.cells.emplace_back();
      for (vtkIdType k = 0; k < ids->GetNumberOfIds(); ++k) cell.push_back(ids->GetId(k));
    }
    return static_cast<std::size_t>(cells->GetNumberOfCells());
  };
  contents.verts = read_cells(data->GetVerts());
  contents.lines = read_cells(data->GetLines());
  contents.polys = read_cells(data->GetPolys());
  contents.point_arrays = read_arrays(data->GetPointData());
  contents.cell_arrays = read_arrays(data->GetCellData());
  vtkFieldData* fields = data->GetFieldData();
  for (int k = 0; k < fields->GetNumberOfArrays(); ++k) {
    if (vtkDataArray* numbers = fields->GetArray(k)) {
      VtpArray array{
          numbers->GetName(), xml_type_name(numbers), numbers->GetNumberOfComponents(), {}};
      for (vtkIdType t = 0; t < numbers->GetNumberOfTuples(); ++t) {
        for (int c = 0; c < array.components; ++c) {
          array.values.push_back(numbers->GetComponent(t, c));
        }
      }
      contents.field_arrays.push_back(array);
    } else if (auto* strings = vtkStringArray::SafeDownCast(fields->GetAbstractArray(k))) {
      std::vector<std::string> values;
      for (vtkIdType v = 0; v < strings->GetNumberOfValues(); ++v) {
        values.push_back(strings->GetValue(v));
      }
      contents.string_fields.emplace_back(strings->GetName(), values);
    }
  }
  return contents;
}

}  // namespace bondem

// The module's entry points (vtk_module.hpp): C linkage, so that dlsym finds them by name.
extern "C" {

__attribute__((visibility("default"))) bondem::VtkSeriesBackend* bondem_vtk_new_series(
    const std::string* directory) {
  return new bondem::VtkSeries(*directory);
}

__attribute__((visibility("default"))) void bondem_vtk_read_vtp(const std::string* path,
                                                                bondem::VtpContents* out) {
  *out = bondem::read_vtp_file(*path);
}

__attribute__((visibility("default"))) void bondem_vtk_particle_array_names(
    const bondem::Particles* particles, const std::vector<std::string>* derived,
    std::vector<std::string>* out) {
  *out = bondem::VtkSeries::particle_array_names(*particles, *derived);
}

}  // extern "C"
