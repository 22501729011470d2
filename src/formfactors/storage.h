// Storage of the N × N form-factor matrix F (row i = receiver patch i, column j = source j).
//
// Four layouts, one interface (everything the solvers, the energy balance and the view-factor
// aggregation need: row products, row updates, row sums, single entries):
//   dense  double   8 N² bytes        the default while most pairs exchange light (a closed room)
//   dense  float    4 N² bytes        half the memory; entries keep ~7 digits (rel. 6e-8)
//   sparse double   12 bytes / entry  CSR-like rows (int32 column, value) for scenes where most
//   sparse float     8 bytes / entry  pairs are zero (back-facing, occluded): rooms with furniture
// Arithmetic is always double: float entries are widened as they are read, so float storage
// changes only the stored factors (by <= 2^-24 relative), never the accumulation.
//
// choose_layout() picks dense or sparse from the expected share of non-zero entries (sampled
// before the fill, see formfactors.h) so that the smaller one is used; `float` is an option.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

namespace photometria {

// Dense N × N, row-major so that a Gauss–Seidel sweep reads rows (also the type tests build).
using FormFactorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

enum class MatrixLayout { Auto, Dense, Sparse };
// Auto (a request only, resolved before the fill: pipeline/memory.h choose_storage): double
// unless only float fits the memory limit.
enum class MatrixPrecision { Double, Float, Auto };

// "auto" | "dense" | "sparse", "auto" | "double" | "float"; parse_* throw Error(BadInput) naming the value.
const char* layout_name(MatrixLayout layout);
const char* precision_name(MatrixPrecision precision);
MatrixLayout parse_layout(const std::string& name);
MatrixPrecision parse_precision(const std::string& name);

// Bytes F takes for n patches with `nonzeros` non-zero entries in the given layout and
// precision (not Auto).
double matrix_bytes(MatrixLayout layout, MatrixPrecision precision, double n, double nonzeros);

// Auto resolved: the layout with the smaller matrix_bytes for the expected non-zero count.
MatrixLayout choose_layout(MatrixLayout requested, MatrixPrecision precision, double n, double nonzeros);

class FormFactors {
 public:
  FormFactors() = default;
  FormFactors(FormFactors&&) = default;
  FormFactors& operator=(FormFactors&&) = default;
  FormFactors(const FormFactors& other);  // deep copy
  FormFactors& operator=(const FormFactors& other);
  // An n × n zero matrix in the given layout and precision (Auto is not allowed here: resolve it
  // first; std::logic_error).
  FormFactors(int n, MatrixLayout layout, MatrixPrecision precision);
  // Dense double, taking the matrix (implicit: tests and small tools build F directly).
  FormFactors(FormFactorMatrix dense);  // NOLINT(google-explicit-constructor)

  int rows() const { return n_; }
  MatrixLayout layout() const { return layout_; }
  MatrixPrecision precision() const { return precision_; }
  // "dense double", "sparse float", ... (the summary's matrix_storage).
  std::string description() const;
  double bytes() const;        // bytes held by the entries (and column indices)
  long long nonzeros() const;  // stored non-zero entries (dense: counted)

  // Replaces row i with `values` (n entries; zeros are not stored in the sparse layouts).
  // Rows may be set concurrently from different threads (distinct i).
  void set_row(int i, const double* values);
  // Dense double only: row i's n entries, written in place by the fill (saves a row buffer and
  // its copy); nullptr for the other layouts. set_row(i, dense_double_row(i)) is a no-op.
  double* dense_double_row(int i) {
    return layout_ == MatrixLayout::Dense && precision_ == MatrixPrecision::Double ? ddata(i) : nullptr;
  }
  // Dense double only (std::logic_error otherwise): hands the N × N entries over without a copy
  // (the view-factor output of one patch per surface is F itself) and leaves this 0 × 0.
  FormFactorMatrix release_dense_double();

  // F_ij (sparse: binary search in row i). Inline: the checks read every entry of a dense F.
  double operator()(int i, int j) const {
    if (layout_ == MatrixLayout::Dense)
      return precision_ == MatrixPrecision::Double ? ddata(i)[j] : double(fdata(i)[j]);
    return sparse_entry(i, j);
  }
  double row_dot(int i, const Eigen::VectorXd& x) const;  // Σ_j F_ij x_j
  // Σ_j F_ij x_j over the columns begin <= j < end only (0 <= begin <= end <= N).
  double row_dot(int i, const Eigen::VectorXd& x, int begin, int end) const;
  double row_sum(int i) const;                                     // Σ_j F_ij
  void add_row_to(int i, double alpha, Eigen::VectorXd& y) const;  // y += alpha · F_i,·
  // Calls fn(j, F_ij) for the stored entries of row i (dense: every entry, zeros included).
  template <class Fn>
  void for_each_in_row(int i, Fn&& fn) const;

  FormFactorMatrix to_dense() const;  // dense double copy (direct solver, enforcement, tests)

  // Dense layouts only: F_ij = F_ji · A_j / A_i for every i > j with mirrored(i, j) true
  // (reciprocity, A_i F_ij = A_j F_ji, for pairs whose upper entry is exact). In 64 × 64 tiles,
  // OpenMP over tile rows. `areas` has N entries, m².
  template <class Pred>
  void mirror_lower(Pred&& mirrored, const double* areas);

 private:
  int n_ = 0;
  MatrixLayout layout_ = MatrixLayout::Dense;
  MatrixPrecision precision_ = MatrixPrecision::Double;
  // Dense entries, row-major (F_ij at i·N + j). Double: an Eigen matrix, so that it can be handed
  // over whole (release_dense_double), zeroed on every core at allocation. Float: from calloc, a
  // large block is fresh zero pages from the kernel, so nothing is written before the fill.
  struct FreeDeleter {
    void operator()(void* p) const { std::free(p); }
  };
  using FloatBlock = std::unique_ptr<float[], FreeDeleter>;
  static FormFactorMatrix allocate_dense_double(int n);
  static FloatBlock allocate_dense_float(int n);
  FormFactorMatrix dense_double_;
  FloatBlock dense_float_;
  double sparse_entry(int i, int j) const;
  double* ddata(int i) { return dense_double_.data() + size_t(i) * size_t(n_); }
  const double* ddata(int i) const { return dense_double_.data() + size_t(i) * size_t(n_); }
  float* fdata(int i) const { return dense_float_.get() + size_t(i) * size_t(n_); }
  std::vector<std::vector<int32_t>> columns_;  // sparse: per row, ascending columns
  std::vector<std::vector<double>> values_double_;
  std::vector<std::vector<float>> values_float_;
};

template <class Fn>
void FormFactors::for_each_in_row(int i, Fn&& fn) const {
  if (layout_ == MatrixLayout::Dense) {
    if (precision_ == MatrixPrecision::Double) {
      const double* row = ddata(i);
      for (int j = 0; j < n_; ++j) fn(j, row[j]);
    } else {
      const float* row = fdata(i);
      for (int j = 0; j < n_; ++j) fn(j, double(row[j]));
    }
    return;
  }
  const std::vector<int32_t>& c = columns_[i];
  if (precision_ == MatrixPrecision::Double)
    for (size_t k = 0; k < c.size(); ++k) fn(int(c[k]), values_double_[i][k]);
  else
    for (size_t k = 0; k < c.size(); ++k) fn(int(c[k]), double(values_float_[i][k]));
}

template <class Pred>
void FormFactors::mirror_lower(Pred&& mirrored, const double* areas) {
  constexpr int kTile = 64;
  const int tiles = (n_ + kTile - 1) / kTile;
  const bool dbl = precision_ == MatrixPrecision::Double;
#pragma omp parallel for schedule(dynamic, 1)
  for (int bi = 0; bi < tiles; ++bi)
    for (int bj = 0; bj <= bi; ++bj) {
      const int i1 = std::min(n_, (bi + 1) * kTile), j1 = std::min(n_, (bj + 1) * kTile);
      for (int i = bi * kTile; i < i1; ++i)
        for (int j = bj * kTile; j < std::min(i, j1); ++j) {
          if (!mirrored(i, j)) continue;
          if (dbl) ddata(i)[j] = ddata(j)[i] * areas[j] / areas[i];
          else fdata(i)[j] = float(double(fdata(j)[i]) * areas[j] / areas[i]);
        }
    }
}

}  // namespace photometria
