// GMRES on the rows of F split over MPI ranks, through PETSc (Balay et al., "PETSc/TAO Users
// Manual", ANL-21/39, Revision 3.18, 2022: KSPGMRES on a MATSHELL operator).
//
//   K B = b,   K = I − diag(ρ) F,   b = E + ρ∘H_direct          (one channel; solver/gmres.h)
//
// Each rank holds only its rows of F (RowBlock). PETSc owns the unknowns in contiguous ranges,
// so its index p runs over the ranks' rows in rank order (parts[0], then parts[1], ...); the
// shell's product gathers x on every rank (a VecScatter to all: N doubles per rank and product),
// and each rank forms its rows of K x with its threads. No preconditioner: diag(K) = 1 − ρ_i F_ii
// = 1 (solver/gmres.h says why GMRES needs few steps here). Restarted GMRES (Saad & Schultz 1986;
// Saad, "Iterative Methods for Sparse Linear Systems", 2nd ed., SIAM 2003, §6.5), restarted
// every 30 steps, with modified Gram–Schmidt as solver/gmres.h.
//
// It stops on the residual of every other solver (solver/solver.h):
//   ‖E + ρ∘(F·B + H_direct) − B‖₂ / ‖B‖₂ <= tolerance,
// computed from B gathered on every rank with the true rows. PETSc's own test is
// ‖b − K x‖₂ <= rtol ‖b‖₂; since B >= b >= 0 entry by entry (B = b + ρ∘F B with F, ρ, B >= 0),
// ‖b‖₂ <= ‖B‖₂, so PETSc stopping at rtol = tolerance meets ours up to GMRES's rounding, which
// the true residual check catches (then PETSc continues from B, ten times tighter).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "solver/block_gauss_seidel.h"
#include "solver/channel.h"
#include "solver/solver.h"

namespace photometria {

// True when the build has PETSc (CMake found petsc-dev with MPI) and its module loads: the first
// call loads libphotometria_petsc.so from the executable's directory (distributed/petsc/
// petsc_gmres_module.h says why PETSc is a module).
bool distributed_gmres_available();
// Why it is not available, in a few words ("" when it is).
std::string distributed_gmres_unavailable_reason();

// Solves one channel from the first guess B = E. `parts`: every rank's rows (parts[r] of rank r;
// the same on every rank), `block` this rank's (block.rows == parts[ranks::rank()]). E, rho, H:
// all N patches' emission (W/m²), reflectance and direct irradiance (W/m²), the same on every
// rank; B (N) is resized and overwritten, and ends the same on every rank. A collective: every
// rank calls it, on MPI that ranks::start() began (PETSc starts on it at the first call and ends
// in ranks::stop()). Iterations count PETSc's products and the true residual checks. Throws
// std::runtime_error on a PETSc failure, or when the build has no PETSc or its module cannot load.
ChannelResult distributed_gmres_channel(const RowBlock& block, const std::vector<std::vector<int>>& parts,
                                        const Eigen::VectorXd& E, const Eigen::VectorXd& rho, const Eigen::VectorXd& H,
                                        const SolverOptions& options, Eigen::VectorXd& B, int restart = 30);

}  // namespace photometria
