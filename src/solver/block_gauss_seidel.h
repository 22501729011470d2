// Block Jacobi–Gauss–Seidel: the radiosity solve when the rows of F are split over processes
// (MPI ranks, distributed/ranks.h), each holding only its own rows.
//
//   B_i = E_i + ρ_i (Σ_j F_ij B_j + H_direct,i)          (docs/theory.md "Units and conventions")
//
// Each process sweeps its own rows in place, in its order, as Gauss–Seidel does (Cohen &
// Greenberg 1985; Cohen & Wallace 1993, §5.3), reading the other processes' B_j as they were
// after the previous sweep: Gauss–Seidel within a block, Jacobi between blocks (block relaxation:
// Saad, Iterative Methods for Sparse Linear Systems, 2nd ed., SIAM 2003, §4.1.1). After each
// sweep the new values are exchanged, so every process holds all of B. It converges under the
// same conditions as Gauss–Seidel (0 <= ρ < 1 and row sums <= 1: K = I − diag(ρ)F is strictly
// diagonally dominant; the splitting K = M − N, M the diagonal and the entries of each row that
// its process updated before it, has ‖M⁻¹N‖∞ < 1 by the argument of Saad's Thm. 4.9 for
// Gauss–Seidel) and stops
// on the same relative residual ‖E + ρ∘(F·B + H_direct) − B‖₂ / ‖B‖₂ <= tolerance, computed
// with all rows. With one process (all rows) it is gauss_seidel_channel's iteration.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <vector>

#include "solver/channel.h"
#include "solver/solver.h"

namespace photometria {

// The rows of F one process holds: rows[k] is the patch of row k of F (rows.size() × N).
struct RowBlock {
  std::vector<int> rows;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> F;
};

// Sums each element of the vector over all processes, in place (every process gets the sums);
// with one process, nothing to do. Every process calls it the same number of times.
using SumOverProcesses = std::function<void(std::vector<double>&)>;

// The residual every solver stops on (solver.h), ‖E + ρ∘(F·B + H) − B‖₂ / ‖B‖₂, from the rows
// of every process (each its block's, summed with `sum`); B: all N patches', the same on every
// process. A collective when the processes are MPI ranks.
double block_relative_residual(const RowBlock& block, const Eigen::VectorXd& E, const Eigen::VectorXd& rho,
                               const Eigen::VectorXd& H, const Eigen::VectorXd& B, const SumOverProcesses& sum);

// Solves one channel from the first guess B = E. E, rho, H: all N patches' emission (W/m²),
// reflectance and direct irradiance (W/m²), the same on every process; B (N) is resized and
// overwritten, and ends the same on every process.
ChannelResult block_gauss_seidel_channel(const RowBlock& block, const Eigen::VectorXd& E, const Eigen::VectorXd& rho,
                                         const Eigen::VectorXd& H, const SolverOptions& options,
                                         const SumOverProcesses& sum, Eigen::VectorXd& B);

}  // namespace photometria
