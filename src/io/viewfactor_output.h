// View-factor matrix writers (`photometria viewfactors --format ...`).
//
// Every writer fills the temporary file of an AtomicOutput (io/atomic_file.h) and does not commit
// it: the caller opens all the outputs of a run before the long computation and commits them
// only when every one was written, so a failed run leaves none of them (and an unwritable path
// is found in a second, not after the fill).
//
// Inputs everywhere: `names` and `areas` (m²) of the n surfaces, F an n × n row-major matrix,
// row i = from surface i. Values are written as the shortest decimal that reads back as the same
// double (the characters of std::to_chars, io/shortest_decimal.h: round-trip exact, at most 17
// significant digits) except in the view3d form, which reproduces View3D's own text output.
// Rows are formatted on every core (OpenMP) and appended in row order past the page cache
// (io/direct_append.h; the binary matrix too), one thread appending while the others format.
//
//   csv     dense: header "name,area,<name_1>,...,<name_n>", then one line per row:
//           "<name_i>,<A_i>,F_i1,...,F_in". Names with commas or quotes are CSV-quoted.
//   sparse  triplets: "# surface,<i>,<name>,<area>" comment lines (0-based i), then the header
//           "i,j,F" and one line per entry with F_ij >= threshold (and F_ij > 0). Zeros are never
//           written; entries below the threshold are dropped and the dropped row sums returned.
//   binary  little-endian: 8 bytes magic "PMVF\0\0\0\1", uint64 n, then for each surface a
//           uint32 byte length and the UTF-8 name, then n float64 areas, then n × n float64 F
//           row-major. Total 16 + Σ(4 + len) + 8 n + 8 n² bytes.
//   view3d  View3D's text view-factor file (its SaveVF with output format 0, View3D 3.2 – 3.5;
//           docs/viewfactors.md has the layout and its sources): a header line
//           "<program> <version> 0 <encl> <emit> <n>" padded with blanks to 30 characters, the n
//           areas ("%g" of the single-precision value, one blank between), n rows of F
//           ("%.6f" of single precision, one blank between), the n emissivities ("%.3f").
//           No names, no title: View3D's readers take numbers only.
#pragma once
#include <Eigen/Core>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "io/atomic_file.h"

namespace photometria {

using ViewFactorRows = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

enum class ViewFactorFormat { Csv, Sparse, Binary, View3d };

struct SparseWriteStats {
  long long written = 0;           // entries written
  long long dropped = 0;           // non-zero entries below the threshold
  double max_dropped_row_sum = 0;  // largest Σ_j of dropped F_ij in one row
  int worst_row = 0;               // that row
  double total_dropped = 0;        // Σ over all dropped entries
};

// One row's share of SparseWriteStats (the sparse form's drops; zero for the others).
struct RowDrops {
  double dropped = 0.0;  // Σ of the dropped entries
  long long dropped_count = 0, written = 0;
};

// What the view3d form writes besides the matrix.
struct View3dOutput {
  std::string program = "Photometria";  // header fields 1 and 2 (View3D writes "View3D 3.2")
  std::string version = "0.1.0";        // as `photometria --version`; View3D's readers take <= 7 chars
  int enclosure = 0;                    // header field 4 (View3D's encl: rows normalised to sum 1)
  int emittances = 0;                   // header field 5 (View3D's didemit: 1 when F holds Hottel's
                                        // exchange factors, script-F, of its C emit=1)
  std::vector<double> emissivities;     // last line, per surface; not n long: 1.0 for every surface
};

// The parts of one form: what comes before the rows, one row, what comes after, as bytes. The
// writers below are made of it, and so are writers that place the rows themselves (the ranks of
// an MPI run, distributed/shared_file.h): header() + row 0 + ... + row n-1 + trailer() are the
// bytes write_view_factors writes. `names` and `areas` must outlive it. Throws Error(Io) for
// Binary on a big-endian host.
class ViewFactorForm {
 public:
  ViewFactorForm(ViewFactorFormat format, const std::vector<std::string>& names, const std::vector<double>& areas,
                 double threshold = 0.0, const View3dOutput& view3d = {});
  int n() const { return static_cast<int>(names_.size()); }
  std::string header() const;
  // Row i (its n entries F_ij) appended to `text`; the sparse form's drops into `drops`.
  void row(int i, const double* F_row, std::string& text, RowDrops& drops) const;
  std::string trailer() const;

 private:
  ViewFactorFormat format_;
  const std::vector<std::string>& names_;
  const std::vector<double>& areas_;
  double threshold_;
  View3dOutput view3d_;
};

// Adds row i's drops to the statistics; called in row order, as the writers do (the worst row is
// then the first of the largest).
void add_row_drops(SparseWriteStats& stats, const RowDrops& row, int i);

// Writes F into `out`'s temporary file (not committed). Throws Error(Io) naming out.target()
// when it cannot be written. `threshold` only applies to Sparse; `view3d` only to View3d.
// Returns the drop statistics (all zero for the dense forms). `progress` (optional) is called with
// the fraction of rows written, about every 1/256 of the rows (one call at a time, from any of
// the formatting threads).
SparseWriteStats write_view_factors(AtomicOutput& out, ViewFactorFormat format, const std::vector<std::string>& names,
                                    const std::vector<double>& areas, const ViewFactorRows& F, double threshold = 0.0,
                                    const View3dOutput& view3d = {},
                                    const std::function<void(double)>& progress = nullptr);

// The matrix written while its rows are computed (`viewfactors --stream`), in any form: the same
// bytes as write_view_factors of the whole matrix, but no row is held after it is written, so
// memory follows the rows in flight instead of n². What comes before the rows is written at
// construction; add_row() may be called from any thread, once per row, in any order: the row is
// formatted on the calling thread, then appended (past the page cache, io/direct_append.h) as
// soon as every row before it is (rows that arrive early wait, formatted, in memory).
class ViewFactorRowStream {
 public:
  // `out`, `names` and `areas` must outlive this object; the rest as write_view_factors.
  ViewFactorRowStream(AtomicOutput& out, ViewFactorFormat format, const std::vector<std::string>& names,
                      const std::vector<double>& areas, double threshold = 0.0, const View3dOutput& view3d = {});
  ~ViewFactorRowStream();
  // Row i's n entries (F_ij, j = 0 .. n-1). Throws Error(Io) naming the file when writing fails.
  void add_row(int i, const double* F_row);
  // Checks that every row arrived (std::logic_error otherwise), writes what follows the rows and
  // returns the drop statistics, equal to write_view_factors'. Throws Error(Io) as add_row.
  SparseWriteStats finish();

 private:
  struct State;  // the form's writer and the appender (viewfactor_output.cpp)
  struct Row {
    std::string text;
    RowDrops drops;
  };
  void write_in_order(Row row, int i);  // with mutex_ held
  AtomicOutput& out_;
  int n_;
  std::unique_ptr<State> state_;
  std::mutex mutex_;
  int next_ = 0;                // the next row to write
  std::map<int, Row> waiting_;  // rows formatted before their turn
  SparseWriteStats stats_;
};

// Point-to-surface factors (P points × G surfaces) as CSV: header "point,<name_1>,...,<name_G>",
// then "<id>,F_1,...,F_G" per point, shortest round-trip decimals, into `out`'s temporary file (not
// committed). Throws Error(Io).
void write_point_factors(AtomicOutput& out, const std::vector<std::string>& point_ids,
                         const std::vector<std::string>& surface_names, const ViewFactorRows& P);

// "csv", "sparse", "binary", "view3d" (the names of `viewfactors --format`).
std::string view_factor_format_name(ViewFactorFormat format);
// The format named `name` (as view_factor_format_name) into `out`; false when unknown.
bool view_factor_format_from_name(const std::string& name, ViewFactorFormat& out);

}  // namespace photometria
