// Successive over-relaxation (SOR) of the radiosity system, one colour channel.
//
// A Gauss–Seidel sweep whose every update is pushed ω times as far (Young 1954, "Iterative
// methods for solving partial difference equations of elliptic type", Trans. AMS 76:92–111,
// the SOR iteration; Saad, Iterative Methods for Sparse Linear Systems, 2nd ed. 2003, §4.1, SOR):
//   g_i = (E_i + ρ_i (Σ_{j≠i} F_ij B_j + H_i)) / (1 − ρ_i F_ii)     (Gauss–Seidel value)
//   B_i ← (1 − ω) B_i + ω g_i
// With reciprocity the row-scaled system diag(A/ρ) − diag(A)F is symmetric positive definite, so
// SOR converges for every 0 < ω < 2 (Ostrowski–Reich theorem: Reich 1949, Ann. Math. Stat. 20;
// Ostrowski 1954, Rend. Mat. Appl. 13); row scaling leaves the SOR iterates unchanged.
//
// Choice of ω (options.omega = 0): Young's optimum for consistently ordered matrices,
//   ω = 2 / (1 + √(1 − μ²))          (Young 1954, the optimum ω_b for consistently ordered matrices)
// where μ is the spectral radius of the Jacobi matrix diag(1−ρF_ii)⁻¹ diag(ρ) F_offdiag, bounded
// here by its largest row sum, μ <= max_i ρ_i Σ_{j≠i} F_ij / (1 − ρ_i F_ii) (Gershgorin). For a
// closed room that bound is exact (μ = ρ: the constant vector). A dense radiosity matrix is not
// consistently ordered, so this ω is a heuristic, not an optimum: docs/performance.md "Solvers"
// shows what it gains on the furnace (a constant factor over Gauss–Seidel, not the √ speed-up
// Young's theory promises for model problems).
#pragma once

#include "solver/channel.h"
#include "solver/solver.h"

namespace photometria {

// Young's ω from the Jacobi bound μ above (1 when μ <= 0).
double young_omega(const FormFactors& F, const Eigen::VectorXd& rho);

// Solves one channel from B = E with the given ω in (0, 2); B (N) is resized and overwritten.
ChannelResult sor_channel(const ChannelProblem& p, double omega, const SolverOptions& options, Eigen::VectorXd& B);

}  // namespace photometria
