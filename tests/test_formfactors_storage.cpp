// Form-factor storage: every layout answers every query like the dense double matrix; the
// solvers give the same radiosity from each; the automatic choice picks the smaller layout.
#include <gtest/gtest.h>

#include <random>

#include "formfactors/formfactors.h"
#include "formfactors/storage.h"
#include "scene_builders.h"
#include "solver/solver.h"
#include "util/error.h"

using namespace photometria;

namespace {

// A random matrix with about `density` of its entries non-zero, values in (0, 0.1].
FormFactorMatrix random_matrix(int n, double density, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  FormFactorMatrix m = FormFactorMatrix::Zero(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      if (u(rng) < density) m(i, j) = 0.1 * (1.0 - u(rng));
  return m;
}

FormFactors stored(const FormFactorMatrix& m, MatrixLayout layout, MatrixPrecision precision) {
  FormFactors f(static_cast<int>(m.rows()), layout, precision);
  for (int i = 0; i < m.rows(); ++i) f.set_row(i, m.row(i).data());
  return f;
}

const MatrixLayout kLayouts[] = {MatrixLayout::Dense, MatrixLayout::Sparse};
const MatrixPrecision kPrecisions[] = {MatrixPrecision::Double, MatrixPrecision::Float};

}  // namespace

TEST(FormFactorStorage, EveryLayoutAnswersLikeTheDenseMatrix) {
  const int n = 37;  // not a multiple of any vector width
  const FormFactorMatrix m = random_matrix(n, 0.3, 5);
  const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(n, -1.0, 2.0);
  const long long nnz = (m.array() != 0.0).count();
  for (MatrixLayout layout : kLayouts)
    for (MatrixPrecision precision : kPrecisions) {
      const FormFactors f = stored(m, layout, precision);
      // float entries are rounded to nearest: relative 2^-24 each.
      const double tol = precision == MatrixPrecision::Float ? 1e-7 : 1e-15;
      SCOPED_TRACE(f.description());
      EXPECT_EQ(f.rows(), n);
      EXPECT_EQ(f.nonzeros(), nnz);
      EXPECT_EQ(f.description(), std::string(layout_name(layout)) + " " + precision_name(precision));
      EXPECT_DOUBLE_EQ(f.bytes(), matrix_bytes(layout, precision, n, double(layout == MatrixLayout::Sparse ? nnz : 0)));
      EXPECT_LE((f.to_dense() - m).cwiseAbs().maxCoeff(), tol * 0.1);
      for (int i = 0; i < n; ++i) {
        EXPECT_NEAR(f.row_dot(i, x), m.row(i).dot(x), tol * m.row(i).cwiseAbs().sum() * 2.0);
        EXPECT_NEAR(f.row_sum(i), m.row(i).sum(), tol * m.row(i).sum() + 1e-300);
        // Column ranges: empty, one column, the ends, and ranges longer than a vector of 8.
        for (auto [begin, end] : {std::pair{0, 0}, {5, 5}, {3, 4}, {0, 9}, {4, 29}, {11, n}, {0, n}, {n, n}}) {
          const Eigen::Index count = end - begin;
          EXPECT_NEAR(f.row_dot(i, x, begin, end), m.row(i).segment(begin, count).dot(x.segment(begin, count)),
                      tol * m.row(i).cwiseAbs().sum() * 2.0 + 1e-300)
              << "columns " << begin << " .. " << end;
        }
        for (int j = 0; j < n; ++j) EXPECT_NEAR(f(i, j), m(i, j), tol * m(i, j));
        Eigen::VectorXd y = Eigen::VectorXd::Ones(n), expected = y + 0.5 * m.row(i).transpose();
        f.add_row_to(i, 0.5, y);
        EXPECT_LE((y - expected).cwiseAbs().maxCoeff(), tol);
      }
    }
}

TEST(FormFactorStorage, SparseStoresOnlyNonZerosAndSetRowReplaces) {
  FormFactors f(4, MatrixLayout::Sparse, MatrixPrecision::Double);
  const double a[4] = {0.0, 0.25, 0.0, 0.5};
  const double b[4] = {0.125, 0.0, 0.0, 0.0};
  f.set_row(2, a);
  EXPECT_EQ(f.nonzeros(), 2);
  f.set_row(2, b);  // replaces, does not add
  EXPECT_EQ(f.nonzeros(), 1);
  EXPECT_EQ(f(2, 0), 0.125);
  EXPECT_EQ(f(2, 3), 0.0);
  EXPECT_EQ(f(0, 0), 0.0);
  int visited = 0;
  f.for_each_in_row(2, [&](int j, double v) {
    ++visited;
    EXPECT_EQ(j, 0);
    EXPECT_EQ(v, 0.125);
  });
  EXPECT_EQ(visited, 1);
}

// check_form_factors reads a dense matrix once, in tiles, with the row sums gathered per thread:
// it must report what a plain pass over every entry reports, for sizes that end inside a tile.
TEST(FormFactorStorage, ChecksEqualAPlainPassOverEveryEntry) {
  for (const int n : {1, 37, 150}) {
    PatchMesh mesh;
    mesh.patches.resize(size_t(n));
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(0.5, 2.0);
    for (Patch& p : mesh.patches) p.area = u(rng);
    FormFactorMatrix m = random_matrix(n, 0.3, 11);
    if (n > 1) {
      m(n - 1, 0) = 0.75;  // the largest entry, below the diagonal in the last tile
      m(0, n - 1) = 0.0;
      m(n - 1, n - 1) = 0.05;  // a diagonal entry counts in the row sum, not in the entries
    }
    for (MatrixLayout layout : kLayouts)
      for (MatrixPrecision precision : kPrecisions) {
        const FormFactors F = stored(m, layout, precision);
        SCOPED_TRACE(F.description() + " n = " + std::to_string(n));
        const FormFactorMatrix d = F.to_dense();
        double min_entry = 1.0, max_entry = 0.0, recip = 0.0;
        for (int i = 0; i < n; ++i)
          for (int j = 0; j < n; ++j) {
            if (j == i) continue;
            min_entry = std::min(min_entry, d(i, j));
            max_entry = std::max(max_entry, d(i, j));
            const double ai = mesh.patches[size_t(i)].area, aj = mesh.patches[size_t(j)].area;
            recip = std::max(recip, std::abs(ai * d(i, j) - aj * d(j, i)) / std::min(ai, aj));
          }
        const Eigen::VectorXd rows = d.rowwise().sum();
        const FormFactorChecks c = check_form_factors(mesh, F);
        EXPECT_EQ(c.min_entry, n == 1 ? 0.0 : min_entry);
        EXPECT_EQ(c.max_entry, max_entry);
        EXPECT_EQ(c.reciprocity_error, recip);
        EXPECT_NEAR(c.min_row_sum, rows.minCoeff(), 1e-14);  // summed in another order
        EXPECT_NEAR(c.max_row_sum, rows.maxCoeff(), 1e-14);
        if (n > 1) {
          EXPECT_EQ(c.max_entry, precision == MatrixPrecision::Float ? double(0.75f) : 0.75);
          EXPECT_EQ(c.min_entry, 0.0);
          EXPECT_GT(c.reciprocity_error, 0.1);
        }
      }
  }
}

TEST(FormFactorStorage, AutoPicksTheSmallerLayout) {
  const double n = 1000;
  // Sparse double costs 12 bytes per entry against 8 per dense entry: break-even at 2/3 density.
  EXPECT_EQ(choose_layout(MatrixLayout::Auto, MatrixPrecision::Double, n, 0.9 * n * n), MatrixLayout::Dense);
  EXPECT_EQ(choose_layout(MatrixLayout::Auto, MatrixPrecision::Double, n, 0.5 * n * n), MatrixLayout::Sparse);
  // Sparse float: 8 bytes per entry against 4: break-even at 1/2.
  EXPECT_EQ(choose_layout(MatrixLayout::Auto, MatrixPrecision::Float, n, 0.6 * n * n), MatrixLayout::Dense);
  EXPECT_EQ(choose_layout(MatrixLayout::Auto, MatrixPrecision::Float, n, 0.4 * n * n), MatrixLayout::Sparse);
  // An explicit request is kept whatever the estimate says.
  EXPECT_EQ(choose_layout(MatrixLayout::Sparse, MatrixPrecision::Double, n, n * n), MatrixLayout::Sparse);
  EXPECT_EQ(choose_layout(MatrixLayout::Dense, MatrixPrecision::Double, n, 0.0), MatrixLayout::Dense);
}

TEST(FormFactorStorage, NamesParseAndBadNamesAreOneLineErrors) {
  EXPECT_EQ(parse_layout("sparse"), MatrixLayout::Sparse);
  EXPECT_EQ(parse_layout("auto"), MatrixLayout::Auto);
  EXPECT_EQ(parse_precision("float"), MatrixPrecision::Float);
  try {
    parse_layout("csr");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::BadInput);
    EXPECT_NE(std::string(e.what()).find("'csr'"), std::string::npos);
  }
  EXPECT_THROW(parse_precision("half"), Error);
}

// The fill stores the same factors in every layout, and every solver method gives the same
// radiosity from each (float to the rounding of its entries).
TEST(FormFactorStorage, FillAndSolversAgreeAcrossLayouts) {
  const PatchMesh mesh = subdivide(builders::unit_cube(), {0.25 + 1e-9, 0.0});
  const int n = mesh.size();
  FillStats stats;
  const FormFactorMatrix reference = fill_form_factors(mesh, FillOptions{}, stats).to_dense();
  ChannelMatrix E = ChannelMatrix::Zero(n, 3), R = ChannelMatrix::Constant(n, 3, 0.8), B, Bref;
  for (int i = 0; i < n; ++i)
    if (mesh.patches[i].normal.z() > 0.5) E.row(i).setConstant(1.0);  // the floor emits
  SolverOptions so;
  so.tolerance = 1e-12;
  so.areas.resize(n);
  for (int i = 0; i < n; ++i) so.areas[i] = mesh.patches[i].area;
  so.method = SolverMethod::Direct;
  solve_radiosity(reference, E, R, ChannelMatrix::Zero(n, 3), true, so, Bref);
  for (MatrixLayout layout : kLayouts)
    for (MatrixPrecision precision : kPrecisions) {
      FillOptions fo;
      fo.layout = layout;
      fo.precision = precision;
      FillStats st;
      const FormFactors F = fill_form_factors(mesh, fo, st);
      SCOPED_TRACE(F.description());
      const double tol = precision == MatrixPrecision::Float ? 1e-7 : 0.0;
      EXPECT_LE((F.to_dense() - reference).cwiseAbs().maxCoeff(), tol);
      const FormFactorChecks c = check_form_factors(mesh, F);
      EXPECT_NEAR(c.max_row_sum, 1.0, 1e-6);
      for (SolverMethod m : {SolverMethod::GaussSeidel, SolverMethod::Sor, SolverMethod::Cg, SolverMethod::Gmres,
                             SolverMethod::Direct}) {
        so.method = m;
        const SolverReport rep = solve_radiosity(F, E, R, ChannelMatrix::Zero(n, 3), true, so, B);
        EXPECT_TRUE(rep.converged) << method_name(m);
        EXPECT_LE(((B - Bref).cwiseAbs().array() / Bref.array()).maxCoeff(),
                  precision == MatrixPrecision::Float ? 1e-6 : 1e-9)
            << method_name(m);
      }
    }
}

// A new matrix is zero in every layout, also when it is large enough for the huge-page path
// (> 8 MiB of entries, from calloc without a memset); a copy owns its entries.
TEST(FormFactorStorage, NewMatricesAreZeroAndCopiesAreDeep) {
  for (const int n : {5, 1100})  // 1100² doubles = 9.2 MiB, floats 4.6 MiB
    for (MatrixLayout layout : kLayouts)
      for (MatrixPrecision precision : kPrecisions) {
        SCOPED_TRACE(std::to_string(n) + " " + layout_name(layout) + " " + precision_name(precision));
        FormFactors f(n, layout, precision);
        EXPECT_EQ(f.nonzeros(), 0);
        for (int i = 0; i < n; i += n / 5) EXPECT_EQ(f.row_sum(i), 0.0);
        std::vector<double> row(static_cast<size_t>(n), 0.0);
        row[1] = 0.25;
        f.set_row(n - 1, row.data());
        FormFactors copy(f);
        row[1] = 0.5;
        f.set_row(n - 1, row.data());
        EXPECT_EQ(copy(n - 1, 1), 0.25);
        EXPECT_EQ(f(n - 1, 1), 0.5);
        copy = f;
        EXPECT_EQ(copy(n - 1, 1), 0.5);
        EXPECT_EQ(copy.nonzeros(), 1);
      }
}

// The fill writes a dense double matrix's rows in place; the other layouts have no such row.
TEST(FormFactorStorage, DenseDoubleRowsAreWrittenInPlace) {
  FormFactors dense(4, MatrixLayout::Dense, MatrixPrecision::Double);
  double* row = dense.dense_double_row(2);
  ASSERT_NE(row, nullptr);
  row[3] = 0.125;
  dense.set_row(2, row);  // a no-op, as the fill calls it
  EXPECT_EQ(dense(2, 3), 0.125);
  EXPECT_EQ(dense.row_sum(2), 0.125);
  EXPECT_EQ(FormFactors(4, MatrixLayout::Dense, MatrixPrecision::Float).dense_double_row(0), nullptr);
  EXPECT_EQ(FormFactors(4, MatrixLayout::Sparse, MatrixPrecision::Double).dense_double_row(0), nullptr);
}
