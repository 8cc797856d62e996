#pragma once
/// @file vtk_output.hpp
/// VTK XML output for ParaView: particle, contact and wall time series (.vtp frames, .pvd index).
///
/// Layout of an output directory after frames 0..N-1:
///   particles_NNNNNN.vtp  one per frame (NNNNNN = frame index, zero padded to six digits)
///   contacts_NNNNNN.vtp   one per frame
///   walls_NNNNNN.vtp      only for frames whose wall geometry differs from the last one written
///   bonds_NNNNNN.vtp      one per frame when the series has bonds (set_bonds_series)
///   particles.pvd, contacts.pvd, walls.pvd (bonds.pvd, tools.pvd)  one DataSet per frame
///   domain.vtp            the domain box as 12 edges, written with the first frame
/// walls.pvd has an entry for every frame, pointing at the wall file current at that frame:
/// ParaView's PVD reader shows, for a requested time, the first entry at or after it, so a sparse
/// list would show a moved wall before it moved. Static walls therefore cost one file.
///
/// A run of several processes writes the particles, contacts and bonds of a frame as one piece
/// per process, `particles_NNNNNN_P.vtp` (P = 0, 1, ...), with a summary `particles_NNNNNN.pvtp`
/// that lists them; the .pvd collections then name the .pvtp files (set_pieces()).
///
/// VTK types stay out of this header: VTK is linked only into the module libbondem_vtk.so
/// (vtk_module.hpp), which bondem loads with the first writer.

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "geometry/boundary.hpp"
#include "geometry/domain.hpp"
#include "solver/engine/particles.hpp"

namespace bondem {

/// One contact or bond as a line between two particle centres (periodic images resolved by the
/// caller: `second_position` is where j is seen from i).
struct ContactRecord {
  std::int64_t id_i = 0;                                      ///< stable id of the first particle
  std::int64_t id_j = 0;                                      ///< stable id of the second particle
  Eigen::Vector3d first_position = Eigen::Vector3d::Zero();   ///< centre of i [m]
  Eigen::Vector3d second_position = Eigen::Vector3d::Zero();  ///< centre of j's image seen from i
  double overlap = 0.0;                                       ///< [m]
  double normal_force = 0.0;                                  ///< signed, as the law returns it [N]
  bool bonded = false;                                        ///< on the adhesive branch
  Eigen::Vector3d force =
      Eigen::Vector3d::Zero();  ///< the pair's force on j (normal + tangential) [N]
};

/// The load the particles put on one boundary in a frame, written with the particles.
struct BoundaryLoadRecord {
  std::string name;
  Eigen::Vector3d force = Eigen::Vector3d::Zero();   ///< [N]
  Eigen::Vector3d moment = Eigen::Vector3d::Zero();  ///< about the boundary's reference point
};

/// A per-particle scalar the caller derives per frame (coordination, bond count), written
/// besides the particles' own fields; `values` has one entry per particle, in the order of
/// Particles, and must stay valid during VtkSeriesWriter::write_frame().
struct VtkScalarField {
  std::string name;
  const std::vector<double>* values = nullptr;
};
/// A derived per-particle 3-vector, as three component arrays (the SoA layout).
struct VtkVectorField {
  std::string name;
  const StaggeredVector<double>* x = nullptr;
  const StaggeredVector<double>* y = nullptr;
  const StaggeredVector<double>* z = nullptr;
};

/// The interface of the VTK series writer in the module libbondem_vtk.so (io/vtk_series.hpp),
/// to which VtkSeriesWriter forwards every call; the methods are VtkSeriesWriter's.
class VtkSeriesBackend {
 public:
  virtual ~VtkSeriesBackend() = default;
  virtual void set_wall_extent(double side) = 0;
  virtual void select_particle_arrays(std::vector<std::string> names) = 0;
  virtual void set_material_names(std::vector<std::string> names) = 0;
  virtual void set_pieces(int piece, int pieces) = 0;
  virtual void publish() const = 0;
  virtual void set_bonds_series(bool on) = 0;
  virtual void set_boundary_loads(std::vector<BoundaryLoadRecord> loads) = 0;
  virtual void write_frame(double time, const Particles& particles,
                           const std::vector<ContactRecord>& contacts,
                           const std::vector<Boundary>& boundaries, const Domain& domain,
                           const std::vector<VtkScalarField>& scalars,
                           const std::vector<VtkVectorField>& vectors) = 0;
  virtual void resume(const std::function<bool(double)>& keep_frame,
                      const std::vector<Boundary>& boundaries, const Domain& domain) = 0;
  virtual std::size_t frames() const = 0;
  virtual const std::string& directory() const = 0;
};

/// Writes a time series for ParaView into one directory (see the file comment for the layout).
/// Files are binary appended, zlib compressed, and each appears whole or not at all (written to
/// `<name>.tmp.<pid>` and renamed); the .pvd collections are rewritten after every frame, so a run
/// that stops early still opens in ParaView.
/// VTK output goes through the module libbondem_vtk.so (vtk_module.hpp), loaded by the first
/// writer or read_vtp: a run without VTK output does not load VTK's libraries (about 30 ms of
/// every start). Throws std::runtime_error naming the places tried when it cannot be loaded.
class VtkSeriesWriter {
 public:
  using ScalarField = VtkScalarField;
  using VectorField = VtkVectorField;

  /// Create @p directory (and missing parents). Throws std::runtime_error naming it on failure.
  explicit VtkSeriesWriter(std::string directory);

  VtkSeriesWriter(const VtkSeriesWriter&) = delete;  // two writers would clobber the .pvd files
  VtkSeriesWriter& operator=(const VtkSeriesWriter&) = delete;
  VtkSeriesWriter(VtkSeriesWriter&&) = default;
  VtkSeriesWriter& operator=(VtkSeriesWriter&&) = default;
  ~VtkSeriesWriter() = default;

  /// Side of the square drawn for each wall before clipping to the domain box [m]; 0 (the
  /// default) uses the domain diagonal, which makes every wall cover its whole cross-section.
  void set_wall_extent(double side);

  /// Write only the particle arrays named in @p names (points are always written); empty: all.
  void select_particle_arrays(std::vector<std::string> names) {
    backend_->select_particle_arrays(std::move(names));
  }

  /// Names of the materials by index: field data "material_names" of every particle file.
  void set_material_names(std::vector<std::string> names) {
    backend_->set_material_names(std::move(names));
  }

  /// Write piece @p piece of @p pieces of every frame (a run of several processes, each with a
  /// writer on the same directory): particles, contacts and bonds go to
  /// `<series>_NNNNNN_<piece>.vtp`; piece 0's writer also writes the `.pvtp` summaries and the
  /// walls, tools and domain, and lists a frame in the collections only when publish() is called,
  /// after every piece of the frame is written. One piece (the default): whole frames, each
  /// listed as it is written.
  void set_pieces(int piece, int pieces);

  /// Piece 0 of a frame in pieces: list the frames written so far in the .pvd collections, once
  /// every process has written its piece of the last one. Otherwise nothing.
  void publish() const;

  /// Also write the bonded contacts as a series of their own, bonds_NNNNNN.vtp.
  void set_bonds_series(bool on) { backend_->set_bonds_series(on); }

  /// The boundary loads of the next frame: field data of its particle file ("boundary_names",
  /// "boundary_force", "boundary_moment", one tuple per boundary).
  void set_boundary_loads(std::vector<BoundaryLoadRecord> loads) {
    backend_->set_boundary_loads(std::move(loads));
  }

  /// Names of the point arrays a particle file of @p particles has, with the derived arrays
  /// @p derived (scalars and vectors alike): what select_particle_arrays() may name.
  static std::vector<std::string> particle_array_names(const Particles& particles,
                                                       const std::vector<std::string>& derived);

  /// Write one frame at simulated time @p time, which must be finite and later than the previous
  /// frame's (a .pvd with repeated times is ambiguous in ParaView).
  ///
  /// particles: points (Float64) with a vertex cell each, by id (a frame does not depend on how
  ///   the run stores the particles); a point array for every field of
  ///   kParticleFields with a VTK name that the particles have (thermal ones only with
  ///   temperatures), by ascending vtk_order: "id" (Int64), "radius", "velocity" (3 components),
  ///   "force" (3), "material" (Int32), the derived @p scalars, "temperature",
  ///   "peak_temperature", "heat_rate", the derived @p vectors, "angular_velocity", "torque".
  ///   A derived field that is one of the particles' own arrays under its table name is written
  ///   once, at its table place; any other repeated name is refused.
  /// contacts: one line per record in the order given, two points of its own each; cell arrays
  /// "overlap",
  ///   "normal_force", "bonded" (UInt8), "id_i", "id_j" (Int64), "normal_force_vector" and
  ///   "tangential_force_vector" (the record's force split along and across the line).
  /// bonds (set_bonds_series): the bonded records alone, with the same arrays.
  /// Particle, contact, bond and tool files carry the field data "TimeValue" (@p time); particle
  ///   files also "material_names" and the boundary loads (set_boundary_loads). domain.vtp, the
  ///   box's 12 edges, is written with the first frame.
  /// walls: one polygon per plane boundary at its current position, a square centred at the
  ///   projection of the domain centre onto the plane, clipped to the domain box (unclipped if the
  ///   plane misses the box); box faces come out as exactly the domain's faces. Cell arrays
  ///   "wall_index" (the plane's place among the planes), "material" (Int32). Written again only
  ///   when the planes differ from the last file's, and every frame while a plane moves.
  /// tools: every other boundary as the outline its shape gives at its current pose (a mesh as
  ///   its triangles), with cell arrays "tool_index" (place among the non-plane boundaries),
  ///   "material".
  ///
  /// Throws std::invalid_argument on bad input (before touching any file) and std::runtime_error
  /// naming the file on a write failure; the frame is then not listed and no temporary remains.
  void write_frame(double time, const Particles& particles,
                   const std::vector<ContactRecord>& contacts,
                   const std::vector<Boundary>& boundaries, const Domain& domain,
                   const std::vector<ScalarField>& scalars = {},
                   const std::vector<VectorField>& vectors = {});

  /// Continue the series a stopped run left in this directory as if it had never stopped: keep
  /// its leading frames (read from walls.pvd) while @p keep_frame(time) holds, remove the files of
  /// every later frame, rewrite the collections and number the next frame after the kept ones.
  /// @p boundaries and @p domain are the geometry the newest kept wall file shows (static planes
  /// do not move; moving ones are drawn every frame), so the next frame reuses that file as an
  /// uninterrupted series would. No series: nothing kept.
  void resume(const std::function<bool(double)>& keep_frame,
              const std::vector<Boundary>& boundaries, const Domain& domain);

  /// Number of frames written.
  std::size_t frames() const { return backend_->frames(); }
  /// The output directory.
  const std::string& directory() const { return backend_->directory(); }

 private:
  std::unique_ptr<VtkSeriesBackend> backend_;
};

/// One data array read back from a .vtp file.
struct VtpArray {
  std::string name;
  std::string type;            ///< VTK XML type name: "Float64", "Int64", "Int32", "UInt8", ...
  int components = 1;          ///< values per tuple
  std::vector<double> values;  ///< tuples one after the other (exact for integers below 2^53)
};

/// The content of a .vtp file, read with VTK's own reader (for tests and tools).
struct VtpContents {
  std::vector<Eigen::Vector3d> points;
  std::vector<std::vector<std::int64_t>> cells;  ///< point ids: verts, then lines, then polygons
  std::size_t verts = 0, lines = 0, polys = 0;   ///< cells of each kind
  std::vector<VtpArray> point_arrays, cell_arrays;
  std::vector<VtpArray> field_arrays;  ///< numeric field data (TimeValue, boundary loads)
  /// String field data by name (material_names, boundary_names).
  std::vector<std::pair<std::string, std::vector<std::string>>> string_fields;

  /// The point array called @p name, or nullptr.
  const VtpArray* point_array(const std::string& name) const;
  /// The cell array called @p name, or nullptr.
  const VtpArray* cell_array(const std::string& name) const;
};

/// Read a .vtp file with vtkXMLPolyDataReader, or a .pvtp summary with vtkXMLPPolyDataReader
/// (its pieces appended in order). Throws std::runtime_error naming the file.
VtpContents read_vtp(const std::string& path);

}  // namespace bondem
