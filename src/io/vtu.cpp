#include "io/vtu.h"

#include <vtkAlgorithm.h>
#include <vtkCallbackCommand.h>
#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkDoubleArray.h>
#include <vtkErrorCode.h>
#include <vtkExecutive.h>
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

// Catches what a VTK algorithm and its executive report through vtkErrorMacro / vtkWarningMacro.
// With an observer on ErrorEvent, VTK hands the message to it instead of printing a multi-line
// block on stderr (vtkOutputWindowDisplayErrorText), so a failure becomes our one-line error.
class VtkErrorCatcher {
 public:
  explicit VtkErrorCatcher(vtkAlgorithm* algorithm) {
    callback_->SetClientData(this);
    callback_->SetCallback(&VtkErrorCatcher::record);
    for (vtkObject* o : {static_cast<vtkObject*>(algorithm), static_cast<vtkObject*>(algorithm->GetExecutive())}) {
      o->AddObserver(vtkCommand::ErrorEvent, callback_);
      o->AddObserver(vtkCommand::WarningEvent, callback_);
    }
  }
  bool failed() const { return errors_ > 0; }
  // The first error's own text, on one line: "ERROR: In file, line N\nclass (0x..): text" -> "text".
  std::string first_error() const { return first_; }

 private:
  static void record(vtkObject*, unsigned long event, void* client, void* call_data) {
    auto* self = static_cast<VtkErrorCatcher*>(client);
    if (event != vtkCommand::ErrorEvent) return;  // warnings: silenced, the outcome is checked anyway
    if (self->errors_++ > 0 || !call_data) return;
    std::string text = static_cast<const char*>(call_data);
    const size_t object_end = text.find("): ");
    if (object_end != std::string::npos) text = text.substr(object_end + 3);
    const size_t line_end = text.find('\n');
    if (line_end != std::string::npos) text.resize(line_end);
    self->first_ = text;
  }
  vtkNew<vtkCallbackCommand> callback_;
  int errors_ = 0;
  std::string first_;
};

}  // namespace

void write_vtu(const std::string& path, const VtuGrid& grid) {
  AtomicOutput out(path);
  write_vtu(out, grid);
  out.commit();
}

void write_vtu(AtomicOutput& out, const VtuGrid& grid) {
  const std::string& path = out.target();
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(static_cast<vtkIdType>(grid.points.size()));
  for (size_t i = 0; i < grid.points.size(); ++i) points->SetPoint(static_cast<vtkIdType>(i), grid.points[i].data());
  vtkNew<vtkUnstructuredGrid> ug;
  ug->SetPoints(points);
  ug->Allocate(static_cast<vtkIdType>(grid.cells.size()));
  for (const auto& cell : grid.cells) {
    std::vector<vtkIdType> ids(cell.begin(), cell.end());
    ug->InsertNextCell(cell.size() == 3 ? VTK_TRIANGLE : VTK_QUAD, static_cast<vtkIdType>(ids.size()), ids.data());
  }
  for (const auto& a : grid.point_arrays) ug->GetPointData()->AddArray(to_vtk(a));
  for (const auto& a : grid.cell_arrays) ug->GetCellData()->AddArray(to_vtk(a));

  // VTK writes into memory and we write its bytes: VTK 9.1's own out-of-disk-space path frees
  // memory it does not own (vtkXMLUnstructuredDataWriter::DeletePositionArrays, caught by
  // AddressSanitizer), so a full disk must never reach it. The stream's errors are ours to check
  // (AtomicOutput::commit).
  vtkNew<vtkXMLUnstructuredGridWriter> writer;
  writer->WriteToOutputStringOn();
  writer->SetInputData(ug);
  writer->SetDataModeToBinary();
  writer->SetCompressorTypeToZLib();
  const VtkErrorCatcher errors(writer);
  const int written = writer->Write();
  const unsigned long code = writer->GetErrorCode();
  if (written != 1 || code != vtkErrorCode::NoError || errors.failed())
    throw_io("cannot write '" + path + "': VTK: " +
             (errors.first_error().empty() ? std::string(vtkErrorCode::GetStringFromErrorCode(code))
                                           : errors.first_error()));
  const std::string bytes = writer->GetOutputString();
  out.stream().write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  out.check_stream();
}

VtuGrid read_vtu(const std::string& path) {
  if (!std::filesystem::exists(path)) throw_io("cannot open '" + path + "'");
  vtkNew<vtkXMLUnstructuredGridReader> reader;
  reader->SetFileName(path.c_str());
  const VtkErrorCatcher errors(reader);
  reader->Update();
  vtkUnstructuredGrid* ug = reader->GetOutput();
  if (!ug || reader->GetErrorCode() != 0 || errors.failed())
    throw_io("cannot read '" + path + "' as a VTK unstructured grid" +
             (errors.first_error().empty() ? std::string() : ": " + errors.first_error()));
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
