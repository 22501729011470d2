// VTK XML unstructured grids (.vtu): what ParaView opens.
//
// Written through VTK's vtkXMLUnstructuredGridWriter, binary and zlib-compressed, atomically
// (io/atomic_file.h). Cells are triangles or quads; arrays are double (or int for indices),
// with 1 or 3 components. Array shapes: point arrays have points.size() tuples, cell arrays
// have cell_count() tuples.
#pragma once

#include <string>
#include <vector>

#include "geometry/polygon.h"
#include "io/atomic_file.h"

namespace photometria {

struct VtuArray {
  std::string name;
  int components = 1;
  std::vector<double> values;  // tuples × components, tuple-major
  bool integer = false;        // written as Int64 (indices)
};

struct VtuGrid {
  std::vector<Vec3> points;
  std::vector<std::vector<int>> cells;  // 3 or 4 point indices each
  std::vector<VtuArray> point_arrays;
  std::vector<VtuArray> cell_arrays;
};

// Writes `grid` to `path` (temporary file + rename). Throws Error(Io) naming the path, also
// when VTK reports an error (an observer catches it: nothing of VTK's is printed) or the bytes
// did not reach the disk; the earlier file at `path` is then untouched.
void write_vtu(const std::string& path, const VtuGrid& grid);
// The same into an output opened earlier (to fail on an unwritable path before a long run);
// the caller commits `out`.
void write_vtu(AtomicOutput& out, const VtuGrid& grid);

// Reads a .vtu back (all point and cell arrays). Throws Error(Io) if it cannot be read.
VtuGrid read_vtu(const std::string& path);

}  // namespace photometria
