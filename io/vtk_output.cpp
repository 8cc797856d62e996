// VtkSeriesWriter and read_vtp: forwards to the module libbondem_vtk.so (vtk_module.hpp), which
// holds the VTK series writer itself (vtk_series.cpp) and VTK's readers.
#include "io/vtk_output.hpp"

#include <utility>

#include "io/vtk_module.hpp"

namespace bondem {
namespace {

const VtpArray* find_array(const std::vector<VtpArray>& arrays, const std::string& name) {
  for (const VtpArray& array : arrays) {
    if (array.name == name) return &array;
  }
  return nullptr;
}

}  // namespace

VtkSeriesWriter::VtkSeriesWriter(std::string directory)
    : backend_(vtk_module_function<VtkSeriesBackend* (*)(const std::string*)>(
          "bondem_vtk_new_series")(&directory)) {}

void VtkSeriesWriter::set_wall_extent(double side) {
  backend_->set_wall_extent(side);
}

void VtkSeriesWriter::set_pieces(int piece, int pieces) {
  backend_->set_pieces(piece, pieces);
}

void VtkSeriesWriter::publish() const {
  backend_->publish();
}

std::vector<std::string> VtkSeriesWriter::particle_array_names(
    const Particles& particles, const std::vector<std::string>& derived) {
  std::vector<std::string> names;
  vtk_module_function<void (*)(const Particles*, const std::vector<std::string>*,
                               std::vector<std::string>*)>("bondem_vtk_particle_array_names")(
      &particles, &derived, &names);
  return names;
}

void VtkSeriesWriter::write_frame(double time, const Particles& particles,
                                  const std::vector<ContactRecord>& contacts,
                                  const std::vector<Boundary>& boundaries, const Domain& domain,
                                  const std::vector<ScalarField>& scalars,
                                  const std::vector<VectorField>& vectors) {
  backend_->write_frame(time, particles, contacts, boundaries, domain, scalars, vectors);
}

void VtkSeriesWriter::resume(const std::function<bool(double)>& keep_frame,
                             const std::vector<Boundary>& boundaries, const Domain& domain) {
  backend_->resume(keep_frame, boundaries, domain);
}

const VtpArray* VtpContents::point_array(const std::string& name) const {
  return find_array(point_arrays, name);
}

const VtpArray* VtpContents::cell_array(const std::string& name) const {
  return find_array(cell_arrays, name);
}

VtpContents read_vtp(const std::string& path) {
  VtpContents contents;
  vtk_module_function<void (*)(const std::string*, VtpContents*)>("bondem_vtk_read_vtp")(&path,
                                                                                         &contents);
  return contents;
}

}  // namespace bondem
