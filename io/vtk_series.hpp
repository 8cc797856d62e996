#pragma once
/// @file vtk_series.hpp
/// The VTK series writer itself (VtkSeriesWriter's backend), compiled into the module
/// libbondem_vtk.so with VTK (vtk_module.hpp); VtkSeriesWriter forwards to it.
#include <optional>
#include <string>
#include <vector>

#include "io/vtk_output.hpp"

namespace bondem {

/// What VtkSeriesWriter documents, with VTK's writers.
class VtkSeries final : public VtkSeriesBackend {
 public:
  using ScalarField = VtkSeriesWriter::ScalarField;
  using VectorField = VtkSeriesWriter::VectorField;
  explicit VtkSeries(std::string directory);
  void set_wall_extent(double side) override;
  void select_particle_arrays(std::vector<std::string> names) override {
    selected_ = std::move(names);
  }
  void set_material_names(std::vector<std::string> names) override {
    material_names_ = std::move(names);
  }
  void set_pieces(int piece, int pieces) override;
  void publish() const override;
  void set_bonds_series(bool on) override { bonds_ = on; }
  void set_boundary_loads(std::vector<BoundaryLoadRecord> loads) override {
    loads_ = std::move(loads);
  }
  void write_frame(double time, const Particles& particles,
                   const std::vector<ContactRecord>& contacts,
                   const std::vector<Boundary>& boundaries, const Domain& domain,
                   const std::vector<ScalarField>& scalars,
                   const std::vector<VectorField>& vectors) override;
  void resume(const std::function<bool(double)>& keep_frame,
              const std::vector<Boundary>& boundaries, const Domain& domain) override;
  std::size_t frames() const override { return times_.size(); }
  const std::string& directory() const override { return directory_; }
  /// VtkSeriesWriter::particle_array_names.
  static std::vector<std::string> particle_array_names(const Particles& particles,
                                                       const std::vector<std::string>& derived);

 private:
  /// What a wall file was drawn from; a frame with the same geometry reuses that file.
  struct WallGeometry {
    std::vector<PlaneWall> walls;
    Domain domain;
    double extent = 0.0;
    bool moving = false;  ///< some plane moves: never reused
    bool same_as(const std::vector<PlaneWall>& other_walls, const Domain& other_domain,
                 double other_extent) const;
  };

  void write_collections() const;
  /// The file of frame @p frame of @p series that the collections list: the frame's .vtp, or for
  /// a frame in pieces its .pvtp summary.
  std::string listed_file(const char* series, std::size_t frame) const;

  std::string directory_;
  double wall_extent_ = 0.0;
  std::vector<double> times_;  ///< time of every frame written
  /// Of every frame written, whether it is in pieces (a restart on another number of processes
  /// continues a series of whole frames in pieces, or the other way round).
  std::vector<bool> in_pieces_;
  std::vector<std::string> wall_files_;      ///< wall file of every frame written
  std::optional<WallGeometry> last_walls_;   ///< geometry of the newest wall file
  bool tools_ = false;                       ///< moving tools were written: keep a tools.pvd series
  std::vector<std::string> selected_;        ///< particle arrays to write; empty: all
  std::vector<std::string> material_names_;  ///< by material index
  std::vector<BoundaryLoadRecord> loads_;    ///< of the next frame
  bool bonds_ = false;                       ///< write the bonds series
  int piece_ = 0, pieces_ = 1;               ///< this writer's piece of each frame, of how many
};

}  // namespace bondem
