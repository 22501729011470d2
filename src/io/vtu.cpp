#include "io/vtu.h"

#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkDoubleArray.h>
#include <vtkIdList.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkTypeInt64Array.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridReader.h>
#include <vtkXMLUnstructuredGridWriter.h>

#include <filesystem>

#include "io/atomic_file.h"
#include "util/error.h"

namespace photometria {
namespace {

vtkSmartPointer<vtkDataArray> to_vtk(const VtuArray& a) {
  vtkSmartPointer<vtkDataArray> arr;
  if (a.integer) arr = vtkSmartPointer<vtkTypeInt64Array>::New();
  else arr = vtkSmartPointer<vtkDoubleArray>::New();
  arr->SetName(a.name.c_str());
  arr->SetNumberOfComponents(a.components);
  const vtkIdType tuples = static_cast<vtkIdType>(a.values.size() / a.components);
  arr->SetNumberOfTuples(tuples);
  for (vtkIdType t = 0; t < tuples; ++t)
    for (int c = 0; c < a.components; ++c) arr->SetComponent(t, c, a.values[t * a.components + c]);
  return arr;
}

VtuArray from_vtk(vtkDataArray* arr) {
  VtuArray a;
  a.name = arr->GetName() ? arr->GetName() : "";
  a.components = arr->GetNumberOfComponents();
  a.integer = arr->GetDataType() != VTK_DOUBLE && arr->GetDataType() != VTK_FLOAT;
  const vtkIdType tuples = arr->GetNumberOfTuples();
  a.values.resize(static_cast<size_t>(tuples) * a.components);
  for (vtkIdType t = 0; t < tuples; ++t)
    for (int c = 0; c < a.components; ++c) a.values[t * a.components + c] = arr->GetComponent(t, c);
  return a;
}

}  // namespace

void write_vtu(const std::string& path, const VtuGrid& grid) {
  AtomicOutput out(path);
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(static_cast<vtkIdType>(grid.points.size()));
  for (size_t i = 0; i < grid.points.size(); ++i)
    points->SetPoint(static_cast<vtkIdType>(i), grid.points[i].data());
  vtkNew<vtkUnstructuredGrid> ug;
  ug->SetPoints(points);
  ug->Allocate(static_cast<vtkIdType>(grid.cells.size()));
  for (const auto& cell : grid.cells) {
    std::vector<vtkIdType> ids(cell.begin(), cell.end());
    ug->InsertNextCell(cell.size() == 3 ? VTK_TRIANGLE : VTK_QUAD, static_cast<vtkIdType>(ids.size()), ids.data());
  }
  for (const auto& a : grid.point_arrays) ug->GetPointData()->AddArray(to_vtk(a));
  for (const auto& a : grid.cell_arrays) ug->GetCellData()->AddArray(to_vtk(a));

  vtkNew<vtkXMLUnstructuredGridWriter> writer;
  writer->SetFileName(out.temp_path().c_str());
  writer->SetInputData(ug);
  writer->SetDataModeToBinary();
  writer->SetCompressorTypeToZLib();
  if (writer->Write() != 1) throw_io("cannot write '" + path + "': VTK writer failed");
  out.commit();
}

VtuGrid read_vtu(const std::string& path) {
  if (!std::filesystem::exists(path)) throw_io("cannot open '" + path + "'");
  vtkNew<vtkXMLUnstructuredGridReader> reader;
  reader->SetFileName(path.c_str());
  reader->Update();
  vtkUnstructuredGrid* ug = reader->GetOutput();
  if (!ug || reader->GetErrorCode() != 0) throw_io("cannot read '" + path + "' as a VTK unstructured grid");
  VtuGrid grid;
  for (vtkIdType i = 0; i < ug->GetNumberOfPoints(); ++i) {
    double x[3];
    ug->GetPoint(i, x);
    grid.points.emplace_back(x[0], x[1], x[2]);
  }
  vtkNew<vtkIdList> ids;
  for (vtkIdType c = 0; c < ug->GetNumberOfCells(); ++c) {
    ug->GetCellPoints(c, ids);
    std::vector<int> cell;
    for (vtkIdType k = 0; k < ids->GetNumberOfIds(); ++k) cell.push_back(static_cast<int>(ids->GetId(k)));
    grid.cells.push_back(cell);
  }
  for (int k = 0; k < ug->GetPointData()->GetNumberOfArrays(); ++k)
    grid.point_arrays.push_back(from_vtk(ug->GetPointData()->GetArray(k)));
  for (int k = 0; k < ug->GetCellData()->GetNumberOfArrays(); ++k)
    grid.cell_arrays.push_back(from_vtk(ug->GetCellData()->GetArray(k)));
  return grid;
}

}  // namespace photometria
