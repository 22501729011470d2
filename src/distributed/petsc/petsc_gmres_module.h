// The interface between the program and its PETSc module (libphotometria_petsc.so).
//
// Why a module: PETSc brings about a hundred shared libraries (HYPRE, MUMPS, HDF5, X11, ...),
// whose loading and relocation cost every start of the program about 50 ms on this project's VM,
// while only `solve --solver gmres` on several MPI ranks needs them. The program loads the module
// (dlopen) on that first call only (distributed/distributed_gmres.cpp); a build without PETSc has
// no module and says so.
//
// The module needs nothing from the program: everything, the common residual included, comes in
// the request, so that it links PETSc, MPI and OpenMP only.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "solver/block_gauss_seidel.h"
#include "solver/channel.h"
#include "solver/solver.h"

namespace photometria {

// One channel's solve (distributed_gmres_channel in distributed/distributed_gmres.h says what
// each field means). `patch_of_index`: PETSc's unknown p is patch patch_of_index[p], the ranks'
// rows concatenated in rank order. `relative_residual(B)`: the common stopping residual with
// every rank's rows (a collective). On failure the module returns nonzero and sets *error.
struct PetscGmresRequest {
  const RowBlock* block = nullptr;
  const std::vector<int>* patch_of_index = nullptr;
  const Eigen::VectorXd *E = nullptr, *rho = nullptr, *H = nullptr;
  const SolverOptions* options = nullptr;
  int restart = 30;
  std::function<double(const Eigen::VectorXd& B)> relative_residual;
  Eigen::VectorXd* B = nullptr;
  ChannelResult* result = nullptr;
  std::string* error = nullptr;
};

// The module's two entry points, looked up by these names.
using PetscGmresSolve = int (*)(PetscGmresRequest* request);  // 0: solved (or stopped at the iteration limit)
using PetscGmresFinalize = void (*)();                        // PetscFinalize, if the module started PETSc
inline constexpr const char* kPetscGmresSolveSymbol = "photometria_petsc_gmres_solve";
inline constexpr const char* kPetscGmresFinalizeSymbol = "photometria_petsc_gmres_finalize";
inline constexpr const char* kPetscModuleFile = "libphotometria_petsc.so";

}  // namespace photometria
