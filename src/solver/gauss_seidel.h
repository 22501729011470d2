// Gauss–Seidel solution of the radiosity system, one colour channel at a time.
//
//   B_i = E_i + ρ_i (Σ_j F_ij B_j + H_direct,i)          (docs/theory.md "Units and conventions")
//
// Sweeps i = 0..N-1 updating B_i in place (Cohen & Greenberg 1985; Cohen & Wallace 1993, §5.3),
// on every thread (channel.h gauss_seidel_sweep: the same iteration, summed in blocks).
// Converges for 0 <= ρ < 1 and row sums Σ_j F_ij <= 1 (the system matrix is strictly diagonally
// dominant). Stops when the relative residual ‖E + ρ∘(F·B + H_direct) − B‖₂ / ‖B‖₂ <= tolerance;
// the (cheap) sweep update norm decides when that residual is worth computing.
//
// In a closed room the error's slowest component is the near-constant one, which a sweep shrinks
// only by about 1 − (1 − ρ)·e^ρ (measured in docs/performance.md "Solvers"): stiff scenes (ρ near 1)
// need the other methods of solver.h. This header also brings in solver.h (SolverOptions,
// SolverReport, solve_radiosity), which is where callers find the solve entry point.
#pragma once

#include "solver/channel.h"
#include "solver/solver.h"

namespace photometria {

// Solves one channel from the first guess B = E; B (N) is resized and overwritten.
ChannelResult gauss_seidel_channel(const ChannelProblem& p, const SolverOptions& options, Eigen::VectorXd& B);

}  // namespace photometria
