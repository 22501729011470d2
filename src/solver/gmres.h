// Restarted GMRES on the radiosity system K B = b, K = I − diag(ρ) F, b = E + ρ∘H (one channel).
//
// Saad & Schultz 1986, "GMRES: a generalized minimal residual algorithm for solving nonsymmetric
// linear systems", SIAM J. Sci. Stat. Comput. 7:856–869; restarted form as in Saad, Iterative
// Methods for Sparse Linear Systems, 2nd ed. 2003, §6.5 (Arnoldi with modified Gram–Schmidt,
// Givens rotations for the least-squares problem, restart every `restart` steps).
// GMRES needs neither symmetry nor patch areas, so it solves the true (only approximately
// reciprocal) F directly. K's spectrum is clustered: eigenvalues 1 − ρ·λ(F), with the isolated
// 1 − ρ of a closed room's constant mode and the rest near 1 (F is a discretised compact
// operator), so few steps are needed even for ρ near 1. No preconditioner: diag(K) = 1 − ρ_i F_ii ≈ 1.
#pragma once

#include "solver/channel.h"
#include "solver/solver.h"

namespace photometria {

// Continues from the B given (N entries; pass B = E for a cold start). `used` matrix-vector
// products already spent count against options.max_iterations; the result's iterations include them.
ChannelResult gmres_channel(const ChannelProblem& p, const SolverOptions& options, Eigen::VectorXd& B, int used = 0,
                            int restart = 30);

}  // namespace photometria
