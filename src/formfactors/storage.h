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
#include <cstdint>
#include <string>
#include <vector>

namespace photometria {

// Dense N × N, row-major so that a Gauss–Seidel sweep reads rows (also the type tests build).
using FormFactorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

enum class MatrixLayout { Auto, Dense, Sparse };
enum class MatrixPrecision { Double, Float };

// "auto" | "dense" | "sparse", "double" | "float"; parse_* throw Error(BadInput) naming the value.
const char* layout_name(MatrixLayout layout);
const char* precision_name(MatrixPrecision precision);
MatrixLayout parse_layout(const std::string& name);
MatrixPrecision parse_precision(const std::string& name);

// Bytes F takes for n patches with `nonzeros` non-zero entries in the given layout (not Auto).
double matrix_bytes(MatrixLayout layout, MatrixPrecision precision, double n, double nonzeros);

// Auto resolved: the layout with the smaller matrix_bytes for the expected non-zero count.
MatrixLayout choose_layout(MatrixLayout requested, MatrixPrecision precision, double n, double nonzeros);

class FormFactors {
 public:
  FormFactors() = default;
  // An n × n zero matrix in the given layout (Auto is not allowed here: resolve it first).
  FormFactors(int n, MatrixLayout layout, MatrixPrecision precision);
  // Dense double, taking the matrix (implicit: tests and small tools build F directly).
  FormFactors(FormFactorMatrix dense);  // NOLINT(google-explicit-constructor)

  int rows() const { return n_; }
  MatrixLayout layout() const { return layout_; }
  MatrixPrecision precision() const { return precision_; }
  // "dense double", "sparse float", ... (the summary's matrix_storage).
  std::string description() const;
  double bytes() const;           // bytes held by the entries (and column indices)
  long long nonzeros() const;     // stored non-zero entries (dense: counted)

  // Replaces row i with `values` (n entries; zeros are not stored in the sparse layouts).
  // Rows may be set concurrently from different threads (distinct i).
  void set_row(int i, const double* values);

  double operator()(int i, int j) const;         // F_ij (sparse: binary search in row i)
  double row_dot(int i, const Eigen::VectorXd& x) const;  // Σ_j F_ij x_j
  double row_sum(int i) const;                   // Σ_j F_ij
  void add_row_to(int i, double alpha, Eigen::VectorXd& y) const;  // y += alpha · F_i,·
  // Calls fn(j, F_ij) for the stored entries of row i (dense: every entry, zeros included).
  template <class Fn>
  void for_each_in_row(int i, Fn&& fn) const;

  FormFactorMatrix to_dense() const;  // dense double copy (direct solver, enforcement, tests)

 private:
  int n_ = 0;
  MatrixLayout layout_ = MatrixLayout::Dense;
  MatrixPrecision precision_ = MatrixPrecision::Double;
  FormFactorMatrix dense_double_;
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> dense_float_;
  std::vector<std::vector<int32_t>> columns_;   // sparse: per row, ascending columns
  std::vector<std::vector<double>> values_double_;
  std::vector<std::vector<float>> values_float_;
};

template <class Fn>
void FormFactors::for_each_in_row(int i, Fn&& fn) const {
  if (layout_ == MatrixLayout::Dense) {
    if (precision_ == MatrixPrecision::Double)
      for (int j = 0; j < n_; ++j) fn(j, dense_double_(i, j));
    else
      for (int j = 0; j < n_; ++j) fn(j, double(dense_float_(i, j)));
    return;
  }
  const std::vector<int32_t>& c = columns_[i];
  if (precision_ == MatrixPrecision::Double)
    for (size_t k = 0; k < c.size(); ++k) fn(int(c[k]), values_double_[i][k]);
  else
    for (size_t k = 0; k < c.size(); ++k) fn(int(c[k]), double(values_float_[i][k]));
}

}  // namespace photometria
