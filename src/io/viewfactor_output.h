// View-factor matrix writers (`photometria viewfactors --format ...`), each written atomically
// (io/atomic_file.h: a failed run never leaves a half-written file).
//
// Inputs everywhere: `names` and `areas` (m²) of the n surfaces, F an n × n row-major matrix,
// row i = from surface i. Values are written with 17 significant digits (round-trip exact)
// except in the view3d form, which copies View3D's fixed 6-decimal text to make diffs easy.
//
//   csv     dense: header "name,area,<name_1>,...,<name_n>", then one line per row:
//           "<name_i>,<A_i>,F_i1,...,F_in". Names with commas or quotes are CSV-quoted.
//   sparse  triplets: "# surface,<i>,<name>,<area>" comment lines (0-based i), then the header
//           "i,j,F" and one line per entry with F_ij >= threshold (and F_ij > 0). Zeros are never
//           written; entries below the threshold are dropped and the dropped row sums returned.
//   binary  little-endian: 8 bytes magic "PMVF\0\0\0\1", uint64 n, then for each surface a
//           uint32 byte length and the UTF-8 name, then n float64 areas, then n × n float64 F
//           row-major. Total 16 + Σ(4 + len) + 8 n + 8 n² bytes.
//   view3d  View3D-style text: "T <title>", "F 3 <n>", "A <A_1> ... <A_n>" then one line per row
//           of F with %.6f values (View3D's text output precision) and the row's name.
#pragma once
#include <Eigen/Core>
#include <string>
#include <vector>

namespace photometria {

using ViewFactorRows = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

enum class ViewFactorFormat { Csv, Sparse, Binary, View3d };

struct SparseWriteStats {
  long long written = 0;          // entries written
  long long dropped = 0;          // non-zero entries below the threshold
  double max_dropped_row_sum = 0; // largest Σ_j of dropped F_ij in one row
  int worst_row = 0;              // that row
  double total_dropped = 0;       // Σ over all dropped entries
};

// Throws Error(Io) when the path cannot be written. `threshold` only applies to Sparse;
// `title` only to View3d. Returns the drop statistics (all zero for the dense forms).
SparseWriteStats write_view_factors(const std::string& path, ViewFactorFormat format,
                                    const std::vector<std::string>& names, const std::vector<double>& areas,
                                    const ViewFactorRows& F, double threshold = 0.0,
                                    const std::string& title = "photometria view factors");

// Point-to-surface factors (P points × G surfaces) as CSV: header "point,<name_1>,...,<name_G>",
// then "<id>,F_1,...,F_G" per point, 17 significant digits. Throws Error(Io).
void write_point_factors(const std::string& path, const std::vector<std::string>& point_ids,
                         const std::vector<std::string>& surface_names, const ViewFactorRows& P);

// "csv", "sparse", "binary", "view3d"; false when unknown.
bool view_factor_format_from_name(const std::string& name, ViewFactorFormat& out);

}  // namespace photometria
