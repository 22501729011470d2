// Direct solve of the radiosity system by dense LU: the reference for small N.
//
// Forms K = I − diag(ρ) F (N × N, a copy: 8·N² bytes) and solves K B = E + ρ∘H with Eigen's
// PartialPivLU (Gaussian elimination with partial pivoting, Golub & Van Loan, Matrix
// Computations, 4th ed. 2013, Algorithm 3.4.1), then up to two steps of iterative refinement
// (ibid. §3.5.3) if the relative residual is still above the tolerance. LU rather than LLT:
// LLT needs the symmetric formulation (cg.h), which is only approximately symmetric when F comes
// from quadrature, whereas LU solves the system exactly as given. K is strictly row diagonally
// dominant (Σ_j ρ_i F_ij <= ρ_i < 1), so it is nonsingular and the factorisation is stable.
// Cost (2/3)·N³ flops: seconds at N ≈ 6,000 on two cores (docs/performance.md "Solvers").
#pragma once

#include "solver/channel.h"
#include "solver/solver.h"

namespace photometria {

// B (N) is overwritten. iterations = 1 + refinement steps.
ChannelResult direct_channel(const ChannelProblem& p, const SolverOptions& options, Eigen::VectorXd& B);

}  // namespace photometria
