// The module libbondem_vtk.so (vtk_module.hpp): VTK's STL reader behind one C-linkage function.
#include <vtkCallbackCommand.h>
#include <vtkCellArray.h>
#include <vtkCommand.h>
#include <vtkIdList.h>
#include <vtkNew.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkSTLReader.h>

#include "io/vtk_module.hpp"

extern "C" __attribute__((visibility("default"))) void bondem_read_stl_geometry(
    const char* path, bondem::StlGeometry* out) {
  vtkNew<vtkSTLReader> reader;
  reader->SetFileName(path);
  reader->MergingOn();
  // With an observer VTK reports its errors to us instead of printing them.
  vtkNew<vtkCallbackCommand> on_error;
  on_error->SetClientData(&out->error);
  on_error->SetCallback([](vtkObject*, unsigned long, void* client, void* call) {
    auto* message = static_cast<std::string*>(client);
    if (message->empty() && call != nullptr) *message = static_cast<const char*>(call);
  });
  reader->AddObserver(vtkCommand::ErrorEvent, on_error);
  reader->Update();
  if (!out->error.empty()) return;
  vtkPolyData* data = reader->GetOutput();
  if (vtkPoints* points = data->GetPoints()) {
    out->points.reserve(static_cast<std::size_t>(points->GetNumberOfPoints()));
    for (vtkIdType k = 0; k < points->GetNumberOfPoints(); ++k) {
      double x[3];
      points->GetPoint(k, x);
      out->points.emplace_back(x[0], x[1], x[2]);
    }
  }
  if (vtkCellArray* polys = data->GetPolys()) {
    vtkNew<vtkIdList> ids;
    for (vtkIdType c = 0; c < polys->GetNumberOfCells(); ++c) {
      polys->GetCellAtId(c, ids);
      std::vector<std::int64_t>& polygon = out->polygons.emplace_back();
      for (vtkIdType k = 0; k < ids->GetNumberOfIds(); ++k) polygon.push_back(ids->GetId(k));
    }
  }
}
