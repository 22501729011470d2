// Conjugate gradients on the symmetric (area-weighted) formulation of the radiosity system.
//
// Multiplying row i of K B = b (K = I − diag(ρ)F, b = E + ρ∘H) by w_i = A_i/ρ_i gives
//   M B = w∘b,   M = diag(A/ρ) − diag(A) F.
// With reciprocity A_i F_ij = A_j F_ji (Cohen & Wallace 1993, ch. 4, the reciprocity relation)
// S = diag(A)F is symmetric, and since Σ_j F_ij <= 1 and ρ < 1, M is symmetric
// and strictly diagonally dominant with a positive diagonal, hence positive definite (Gershgorin),
// so conjugate gradients apply (Hestenes & Stiefel 1952, J. Res. NBS 49:409–436; here
// Jacobi-preconditioned, Saad 2003 Algorithm 9.1). With the Jacobi preconditioner the iteration
// sees the spectrum of K itself: a closed room's isolated eigenvalue 1 − ρ (the constant mode,
// the one that stalls Gauss–Seidel) and the rest clustered near 1, which CG resolves in a
// handful of steps whatever ρ is.
//
// Patches with ρ_i = 0 have B_i = E_i exactly; they are fixed first and left out of M (their
// light enters the others through the residual), so w_i = A_i/ρ_i is never formed for them.
//
// F from quadrature is only approximately reciprocal. What is done about it, honestly:
//   - the asymmetry ‖S − Sᵀ‖_F / ‖S‖_F is measured and reported (reciprocity_error());
//   - CG runs on the symmetric part M_s = diag(A/ρ) − (S + Sᵀ)/2 (both F·p and Fᵀ·(A∘p) come from
//     one pass over F), while the residual of the TRUE system K B = b is updated alongside
//     (r ← r − α K p costs nothing extra: F·p is already there);
//   - when that true residual stops following CG's own (the asymmetric part now dominates), CG
//     restarts on the current true residual: iterative refinement with M_s as the approximate
//     inverse (Golub & Van Loan, Matrix Computations, 4th ed. 2013, §3.5.3);
//   - if a restart cycle fails to halve the true residual, or M_s turns out not to be positive
//     definite, the solve continues from the current B with GMRES on K (gmres.h), and says so.
// Success is only ever declared on the true residual recomputed from F (solver.h).
#pragma once

#include "solver/channel.h"
#include "solver/solver.h"

namespace photometria {

// ‖S − Sᵀ‖_F / ‖S‖_F with S = diag(areas) F (0 = exactly reciprocal). One blocked pass over F.
double reciprocity_error(const FormFactors& F, const Eigen::VectorXd& areas);

// Solves one channel from B = E; `areas` are the N patch areas (m², all > 0). B is overwritten.
ChannelResult cg_channel(const ChannelProblem& p, const Eigen::VectorXd& areas, const SolverOptions& options,
                         Eigen::VectorXd& B);

}  // namespace photometria
