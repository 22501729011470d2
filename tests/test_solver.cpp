#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <barrier>
#include <numeric>
#include <random>
#include <thread>

#include "formfactors/formfactors.h"
#include "formfactors/storage.h"
#include "scene_builders.h"
#include "solver/block_gauss_seidel.h"
#include "solver/gauss_seidel.h"
#include "util/error.h"

using namespace photometria;

namespace {
FormFactorMatrix furnace_matrix(const PatchMesh& mesh) {
  FillStats stats;
  return fill_form_factors(mesh, FillOptions{}, stats).to_dense();
}
}  // namespace

// White furnace: closed room, uniform E and ρ: B = E / (1 − ρ) everywhere.
TEST(GaussSeidel, WhiteFurnaceMatchesTheClosedForm) {
  const PatchMesh mesh = subdivide(builders::unit_cube(), {0.25, 0.0});
  const FormFactorMatrix F = furnace_matrix(mesh);
  const int n = mesh.size();
  for (double rho : {0.5, 0.9, 0.99}) {
    ChannelMatrix E = ChannelMatrix::Constant(n, 3, 1.0), R = ChannelMatrix::Constant(n, 3, rho), B;
    const SolverReport rep = solve_radiosity(F, E, R, ChannelMatrix::Zero(n, 3), true, {1e-12, 100000}, B);
    EXPECT_TRUE(rep.converged);
    EXPECT_EQ(rep.channels_solved, 1);
    EXPECT_LE(rep.residual, 1e-12);
    for (int i = 0; i < n; ++i) EXPECT_NEAR(B(i, 0) * (1 - rho), 1.0, 1e-9) << "rho " << rho;
  }
}

TEST(GaussSeidel, ColouredChannelsAreSolvedSeparately) {
  const PatchMesh mesh = subdivide(builders::unit_cube(), {0.5, 0.0});
  const FormFactorMatrix F = furnace_matrix(mesh);
  const int n = mesh.size();
  ChannelMatrix E = ChannelMatrix::Constant(n, 3, 1.0), R(n, 3), B;
  R.col(0).setConstant(0.2);
  R.col(1).setConstant(0.5);
  R.col(2).setConstant(0.8);
  const SolverReport rep = solve_radiosity(F, E, R, ChannelMatrix::Zero(n, 3), false, {1e-12, 10000}, B);
  EXPECT_EQ(rep.channels_solved, 3);
  EXPECT_NEAR(B(0, 0), 1.25, 1e-9);
  EXPECT_NEAR(B(0, 1), 2.0, 1e-9);
  EXPECT_NEAR(B(0, 2), 5.0, 1e-9);
}

// The blocked sweep (channel.h gauss_seidel_sweep) is the row-by-row Gauss–Seidel sweep: rows
// updated once each, in order, each from the values of the rows before it in this sweep and of
// those after it in the last; the same to rounding in every storage, bit for bit on 1 or 2 threads.
TEST(GaussSeidel, BlockedSweepIsTheRowByRowSweep) {
  const int n = 3 * kSweepBlock + 37;  // blocks of the full size and a partial one
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  FormFactorMatrix m = FormFactorMatrix::Zero(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      if (u(rng) < 0.4) m(i, j) = 0.002 * u(rng);
  Eigen::VectorXd start(n), rho(n);
  for (int i = 0; i < n; ++i) start[i] = u(rng), rho[i] = 0.9 * u(rng);
  const Eigen::VectorXd E = Eigen::VectorXd::LinSpaced(n, 0.0, 1.0);
  // Two sweeps row by row on the dense double matrix.
  Eigen::VectorXd want = start;
  for (int sweep = 0; sweep < 2; ++sweep)
    for (int i = 0; i < n; ++i) want[i] = E[i] + rho[i] * m.row(i).dot(want);
  const int threads = omp_get_max_threads();
  for (MatrixLayout layout : {MatrixLayout::Dense, MatrixLayout::Sparse})
    for (MatrixPrecision precision : {MatrixPrecision::Double, MatrixPrecision::Float}) {
      FormFactors f(n, layout, precision);
      for (int i = 0; i < n; ++i) f.set_row(i, m.row(i).data());
      SCOPED_TRACE(f.description());
      Eigen::VectorXd per_thread_count[2];
      for (int t : {1, 2}) {
        omp_set_num_threads(t);
        Eigen::VectorXd B = start;
        for (int sweep = 0; sweep < 2; ++sweep) {
          int next = 0;  // the row the sweep must update next
          gauss_seidel_sweep(f, B, [&](int i, double fb) {
            EXPECT_EQ(i, next);
            next = i + 1;
            return E[i] + rho[i] * fb;
          });
          EXPECT_EQ(next, n);
        }
        // float entries are rounded to nearest (2^-24 relative); B ~ 1 and Σ_j F_ij < 1.
        const double tol = precision == MatrixPrecision::Float ? 1e-7 : 1e-14;
        EXPECT_LE((B - want).cwiseAbs().maxCoeff(), tol);
        per_thread_count[t - 1] = B;
      }
      EXPECT_TRUE(per_thread_count[0] == per_thread_count[1]) << "the result depends on the thread count";
    }
  omp_set_num_threads(threads);
}

// A grey claim with coloured direct light (grey materials under a red light): every channel is
// solved, not the first one copied.
TEST(GaussSeidel, GreyClaimWithColouredLightSolvesEveryChannel) {
  const PatchMesh mesh = subdivide(builders::unit_cube(), {0.5, 0.0});
  const FormFactorMatrix F = furnace_matrix(mesh);
  const int n = mesh.size();
  ChannelMatrix E = ChannelMatrix::Zero(n, 3), R = ChannelMatrix::Constant(n, 3, 0.5), H(n, 3), B;
  H.col(0).setConstant(1.0);
  H.col(1).setConstant(0.4);
  H.col(2).setConstant(0.0);
  const SolverReport rep = solve_radiosity(F, E, R, H, true, {1e-12, 10000}, B);
  EXPECT_EQ(rep.channels_solved, 3);
  // Closed room, uniform H and ρ: B = ρ H / (1 − ρ) everywhere.
  for (int i = 0; i < n; ++i) {
    EXPECT_NEAR(B(i, 0), 1.0, 1e-9);
    EXPECT_NEAR(B(i, 1), 0.4, 1e-9);
    EXPECT_NEAR(B(i, 2), 0.0, 1e-12);
  }
}

TEST(GaussSeidel, RefusesReflectanceOfOneAndNegativeEmission) {
  const PatchMesh mesh = subdivide(builders::unit_cube(), {});
  const FormFactorMatrix F = furnace_matrix(mesh);
  ChannelMatrix E = ChannelMatrix::Constant(6, 3, 1.0), R = ChannelMatrix::Constant(6, 3, 0.5), B;
  R(3, 1) = 1.0;
  try {
    solve_radiosity(F, E, R, ChannelMatrix::Zero(6, 3), false, {}, B);
    FAIL() << "ρ = 1 accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::BadInput);
    EXPECT_NE(std::string(e.what()).find("reflectance 1"), std::string::npos) << e.what();
  }
  R(3, 1) = 0.5;
  E(2, 0) = -1;
  EXPECT_THROW(solve_radiosity(F, E, R, ChannelMatrix::Zero(6, 3), false, {}, B), Error);
}

TEST(GaussSeidel, ReportsNonConvergenceAtTheCap) {
  const PatchMesh mesh = subdivide(builders::unit_cube(), {0.5, 0.0});
  const FormFactorMatrix F = furnace_matrix(mesh);
  const int n = mesh.size();
  ChannelMatrix E = ChannelMatrix::Constant(n, 3, 1.0), R = ChannelMatrix::Constant(n, 3, 0.99), B;
  const SolverReport rep =
      solve_radiosity(F, E, R, ChannelMatrix::Zero(n, 3), true, {1e-12, 5, SolverMethod::GaussSeidel}, B);
  EXPECT_FALSE(rep.converged);
  EXPECT_EQ(rep.iterations, 5);
  EXPECT_GT(rep.residual, 1e-12);
}

namespace {

// Block Jacobi–Gauss–Seidel's problem: the unit cube's form factors with coloured emission and
// ρ = 0.7, and the rows `rows` of F as one process's block.
struct BlockProblem {
  FormFactorMatrix F;
  Eigen::VectorXd E, rho, H;
  RowBlock block(const std::vector<int>& rows) const {
    RowBlock b;
    b.rows = rows;
    b.F.resize(Eigen::Index(rows.size()), F.cols());
    for (size_t k = 0; k < rows.size(); ++k) b.F.row(Eigen::Index(k)) = F.row(rows[k]).cast<double>();
    return b;
  }
};

BlockProblem block_problem() {
  const PatchMesh mesh = subdivide(builders::unit_cube(), {0.25, 0.0});
  BlockProblem p{furnace_matrix(mesh), {}, {}, {}};
  const int n = mesh.size();
  p.E = Eigen::VectorXd::Zero(n);
  for (int i = 0; i < n; i += 7) p.E[i] = 1.0 + 0.1 * i;
  p.rho = Eigen::VectorXd::Constant(n, 0.7);
  p.H = Eigen::VectorXd::LinSpaced(n, 0.0, 0.5);
  return p;
}

}  // namespace

// With every row in one block and no other process it is Gauss–Seidel: the same B.
TEST(BlockGaussSeidel, OneProcessHoldingEveryRowIsGaussSeidel) {
  const BlockProblem p = block_problem();
  const int n = static_cast<int>(p.E.size());
  std::vector<int> rows(static_cast<size_t>(n));
  std::iota(rows.begin(), rows.end(), 0);
  const SolverOptions opt{1e-13, 10000};
  Eigen::VectorXd block_b, serial_b;
  const ChannelResult r = block_gauss_seidel_channel(
      p.block(rows), p.E, p.rho, p.H, opt, [](std::vector<double>&) {}, block_b);
  const FormFactors F(p.F);
  const ChannelResult s = gauss_seidel_channel(ChannelProblem{F, p.E, p.rho, p.H}, opt, serial_b);
  ASSERT_TRUE(r.converged);
  ASSERT_TRUE(s.converged);
  EXPECT_LE(r.residual, 1e-13);
  EXPECT_NEAR(r.iterations, s.iterations, 1);
  EXPECT_LE((block_b - serial_b).norm() / serial_b.norm(), 1e-12);
}

// Two processes (threads here, summing through shared slots) holding the rows in two shuffled
// halves: Jacobi between the blocks, Gauss–Seidel within them, the same B as one process.
TEST(BlockGaussSeidel, TwoProcessesReachTheSameRadiosityAsOne) {
  const BlockProblem p = block_problem();
  const int n = static_cast<int>(p.E.size());
  std::vector<int> rows(static_cast<size_t>(n));
  std::iota(rows.begin(), rows.end(), 0);
  std::shuffle(rows.begin(), rows.end(), std::mt19937(5));
  const std::vector<int> first(rows.begin(), rows.begin() + n / 3), second(rows.begin() + n / 3, rows.end());
  const SolverOptions opt{1e-13, 10000};
  std::vector<double> slot[2];
  std::barrier sync(2);
  auto sum_of = [&](int me) {
    return [&, me](std::vector<double>& v) {
      slot[me] = v;
      sync.arrive_and_wait();
      for (size_t k = 0; k < v.size(); ++k) v[k] = slot[0][k] + slot[1][k];
      sync.arrive_and_wait();  // both have read before either writes again
    };
  };
  Eigen::VectorXd b[2];
  ChannelResult r[2];
  std::thread other([&] { r[1] = block_gauss_seidel_channel(p.block(second), p.E, p.rho, p.H, opt, sum_of(1), b[1]); });
  r[0] = block_gauss_seidel_channel(p.block(first), p.E, p.rho, p.H, opt, sum_of(0), b[0]);
  other.join();
  Eigen::VectorXd serial_b;
  const FormFactors F(p.F);
  gauss_seidel_channel(ChannelProblem{F, p.E, p.rho, p.H}, opt, serial_b);
  for (int me : {0, 1}) {
    ASSERT_TRUE(r[me].converged);
    EXPECT_EQ(r[me].iterations, r[0].iterations);
    EXPECT_EQ(b[me], b[0]);  // every process ends with all of B
  }
  EXPECT_LE((b[0] - serial_b).norm() / serial_b.norm(), 1e-12);
}
