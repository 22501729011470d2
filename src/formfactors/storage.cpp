#include "formfactors/storage.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <type_traits>

#include "util/error.h"
#include "util/huge_pages.h"

namespace photometria {

namespace {

// Σ_{j < count} term(j) in eight partial sums: one running sum would wait on each addition's
// latency (the compiler may not reorder a floating-point sum), eight independent ones vectorize.
template <class Term>
double sum_in_eight(int count, Term term) {
  double acc[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  int j = 0;
  for (; j + 8 <= count; j += 8)
    for (int k = 0; k < 8; ++k) acc[k] += term(j + k);
  double sum = ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7]));
  for (; j < count; ++j) sum += term(j);
  return sum;
}

}  // namespace

const char* layout_name(MatrixLayout layout) {
  switch (layout) {
    case MatrixLayout::Auto: return "auto";
    case MatrixLayout::Dense: return "dense";
    case MatrixLayout::Sparse: return "sparse";
  }
  return "?";
}

const char* precision_name(MatrixPrecision precision) {
  switch (precision) {
    case MatrixPrecision::Double: return "double";
    case MatrixPrecision::Float: return "float";
    case MatrixPrecision::Auto: return "auto";
  }
  return "?";
}

MatrixLayout parse_layout(const std::string& name) {
  if (name == "auto") return MatrixLayout::Auto;
  if (name == "dense") return MatrixLayout::Dense;
  if (name == "sparse") return MatrixLayout::Sparse;
  throw Error(ErrorKind::BadInput, "unknown matrix layout '" + name + "' (expected auto, dense or sparse)");
}

MatrixPrecision parse_precision(const std::string& name) {
  if (name == "double") return MatrixPrecision::Double;
  if (name == "float") return MatrixPrecision::Float;
  if (name == "auto") return MatrixPrecision::Auto;
  throw Error(ErrorKind::BadInput, "unknown matrix precision '" + name + "' (expected auto, double or float)");
}

double matrix_bytes(MatrixLayout layout, MatrixPrecision precision, double n, double nonzeros) {
  const double value = precision == MatrixPrecision::Double ? 8.0 : 4.0;
  if (layout == MatrixLayout::Sparse)
    return nonzeros * (value + 4.0) + n * 2.0 * sizeof(std::vector<int32_t>);  // entries + row headers
  return n * n * value;
}

MatrixLayout choose_layout(MatrixLayout requested, MatrixPrecision precision, double n, double nonzeros) {
  if (requested != MatrixLayout::Auto) return requested;
  return matrix_bytes(MatrixLayout::Sparse, precision, n, nonzeros) <
                 matrix_bytes(MatrixLayout::Dense, precision, n, nonzeros)
             ? MatrixLayout::Sparse
             : MatrixLayout::Dense;
}

FormFactorMatrix FormFactors::allocate_dense_double(int n) {
  FormFactorMatrix m(n, n);  // uninitialised: not a page is touched yet
  // Huge pages for the N² entries that the fill writes and every solver sweep streams.
  advise_huge_pages(m.data(), sizeof(double) * size_t(m.size()));
  // Zeroed row by row on every core: the page faults (the kernel clears each page) are shared.
#pragma omp parallel for schedule(static)
  for (int i = 0; i < n; ++i) std::memset(m.data() + size_t(i) * size_t(n), 0, sizeof(double) * size_t(n));
  return m;
}

FormFactors::FloatBlock FormFactors::allocate_dense_float(int n) {
  const size_t count = size_t(n) * size_t(n);
  // calloc, not malloc + memset: glibc serves a large block with fresh pages from mmap, which
  // the kernel zeroes on first touch (during the fill, on every thread), so nothing is written
  // twice. Small blocks are zeroed by calloc itself.
  FloatBlock block(static_cast<float*>(std::calloc(std::max<size_t>(count, 1), sizeof(float))));
  if (!block) throw std::bad_alloc();
  advise_huge_pages(block.get(), count * sizeof(float));
  return block;
}

FormFactors::FormFactors(const FormFactors& other)
    : n_(other.n_),
      layout_(other.layout_),
      precision_(other.precision_),
      dense_double_(other.dense_double_),
      columns_(other.columns_),
      values_double_(other.values_double_),
      values_float_(other.values_float_) {
  if (other.dense_float_) {
    dense_float_ = allocate_dense_float(n_);
    std::memcpy(dense_float_.get(), other.dense_float_.get(), size_t(n_) * size_t(n_) * sizeof(float));
  }
}

FormFactors& FormFactors::operator=(const FormFactors& other) {
  if (this != &other) *this = FormFactors(other);
  return *this;
}

FormFactors::FormFactors(int n, MatrixLayout layout, MatrixPrecision precision)
    : n_(n), layout_(layout), precision_(precision) {
  if (layout == MatrixLayout::Auto) throw std::logic_error("FormFactors: resolve the layout before allocating");
  if (precision == MatrixPrecision::Auto)
    throw std::logic_error("FormFactors: resolve the precision before allocating");
  if (layout == MatrixLayout::Dense) {
    if (precision == MatrixPrecision::Double) dense_double_ = allocate_dense_double(n);
    else dense_float_ = allocate_dense_float(n);
    return;
  }
  columns_.resize(n);
  if (precision == MatrixPrecision::Double) values_double_.resize(n);
  else values_float_.resize(n);
}

FormFactors::FormFactors(FormFactorMatrix dense)
    : n_(static_cast<int>(dense.rows())), dense_double_(std::move(dense)) {}

FormFactorMatrix FormFactors::release_dense_double() {
  if (layout_ != MatrixLayout::Dense || precision_ != MatrixPrecision::Double)
    throw std::logic_error("FormFactors::release_dense_double: the matrix is not dense double");
  FormFactorMatrix out = std::move(dense_double_);
  dense_double_ = FormFactorMatrix();
  n_ = 0;
  return out;
}

std::string FormFactors::description() const {
  return std::string(layout_name(layout_)) + " " + precision_name(precision_);
}

double FormFactors::bytes() const {
  return matrix_bytes(layout_, precision_, n_, double(layout_ == MatrixLayout::Sparse ? nonzeros() : 0));
}

long long FormFactors::nonzeros() const {
  long long count = 0;
  if (layout_ == MatrixLayout::Sparse) {
    for (const auto& c : columns_) count += static_cast<long long>(c.size());
    return count;
  }
  const size_t entries = size_t(n_) * size_t(n_);
  if (precision_ == MatrixPrecision::Double)
    return static_cast<long long>(
        std::count_if(dense_double_.data(), dense_double_.data() + entries, [](double f) { return f != 0.0; }));
  return static_cast<long long>(
      std::count_if(dense_float_.get(), dense_float_.get() + entries, [](float f) { return f != 0.0f; }));
}

void FormFactors::set_row(int i, const double* values) {
  if (layout_ == MatrixLayout::Dense) {
    if (precision_ == MatrixPrecision::Double) {
      if (values != ddata(i)) std::memcpy(ddata(i), values, size_t(n_) * sizeof(double));
    } else {
      float* row = fdata(i);
      for (int j = 0; j < n_; ++j) row[j] = float(values[j]);
    }
    return;
  }
  std::vector<int32_t>& c = columns_[i];
  c.clear();
  for (int j = 0; j < n_; ++j)
    if (values[j] != 0.0) c.push_back(j);
  c.shrink_to_fit();
  if (precision_ == MatrixPrecision::Double) {
    std::vector<double>& v = values_double_[i];
    v.resize(c.size());
    for (size_t k = 0; k < c.size(); ++k) v[k] = values[c[k]];
  } else {
    std::vector<float>& v = values_float_[i];
    v.resize(c.size());
    for (size_t k = 0; k < c.size(); ++k) v[k] = float(values[c[k]]);
  }
}

double FormFactors::sparse_entry(int i, int j) const {
  const std::vector<int32_t>& c = columns_[i];
  const auto it = std::lower_bound(c.begin(), c.end(), j);
  if (it == c.end() || *it != j) return 0.0;
  const size_t k = size_t(it - c.begin());
  return precision_ == MatrixPrecision::Double ? values_double_[i][k] : double(values_float_[i][k]);
}

double FormFactors::row_dot(int i, const Eigen::VectorXd& x) const { return row_dot(i, x, 0, n_); }

double FormFactors::row_dot(int i, const Eigen::VectorXd& x, int begin, int end) const {
  if (layout_ == MatrixLayout::Dense) {
    const int count = end - begin;
    if (precision_ == MatrixPrecision::Double)
      return Eigen::Map<const Eigen::RowVectorXd>(ddata(i) + begin, count).dot(x.segment(begin, count).transpose());
    const float* row = fdata(i) + begin;
    const double* xs = x.data() + begin;
    return sum_in_eight(count, [&](int j) { return double(row[j]) * xs[j]; });
  }
  const std::vector<int32_t>& c = columns_[i];
  // Columns are ascending: the range is one run of them.
  const size_t k0 = begin <= 0 ? 0 : size_t(std::lower_bound(c.begin(), c.end(), begin) - c.begin());
  const size_t k1 = end >= n_ ? c.size() : size_t(std::lower_bound(c.begin() + long(k0), c.end(), end) - c.begin());
  double sum = 0.0;
  if (precision_ == MatrixPrecision::Double) {
    const std::vector<double>& v = values_double_[i];
    for (size_t k = k0; k < k1; ++k) sum += v[k] * x[c[k]];
  } else {
    const std::vector<float>& v = values_float_[i];
    for (size_t k = k0; k < k1; ++k) sum += double(v[k]) * x[c[k]];
  }
  return sum;
}

double FormFactors::row_sum(int i) const {
  if (layout_ == MatrixLayout::Dense) {
    if (precision_ == MatrixPrecision::Double) return Eigen::Map<const Eigen::RowVectorXd>(ddata(i), n_).sum();
    const float* row = fdata(i);
    return sum_in_eight(n_, [&](int j) { return double(row[j]); });
  }
  double sum = 0.0;
  for_each_in_row(i, [&](int, double f) { sum += f; });
  return sum;
}

void FormFactors::add_row_to(int i, double alpha, Eigen::VectorXd& y) const {
  if (layout_ == MatrixLayout::Dense && precision_ == MatrixPrecision::Double) {
    y.noalias() += alpha * Eigen::Map<const Eigen::VectorXd>(ddata(i), n_);
    return;
  }
  for_each_in_row(i, [&](int j, double f) { y[j] += alpha * f; });
}

FormFactorMatrix FormFactors::to_dense() const {
  if (layout_ == MatrixLayout::Dense && precision_ == MatrixPrecision::Double) return dense_double_;
  if (layout_ == MatrixLayout::Dense)
    return Eigen::Map<const Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(dense_float_.get(),
                                                                                                   n_, n_)
        .cast<double>();
  FormFactorMatrix d = FormFactorMatrix::Zero(n_, n_);
  for (int i = 0; i < n_; ++i) for_each_in_row(i, [&](int j, double f) { d(i, j) = f; });
  return d;
}

}  // namespace photometria
