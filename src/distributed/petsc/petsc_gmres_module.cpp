// libphotometria_petsc.so: GMRES on the rows of F split over MPI ranks, through PETSc
// (petsc_gmres_module.h says why it is a module; distributed/distributed_gmres.h the method and
// its sources). Built only where CMake finds PETSc; the program loads it on first use.
#include <petscksp.h>

#include <cmath>
#include <exception>
#include <stdexcept>
#include <string>

#include "distributed/petsc/petsc_gmres_module.h"

namespace photometria {

namespace {

// A failed PETSc call as an exception (PETSc's own handler would print a trace and abort).
void check(PetscErrorCode code, const char* call) {
  if (code == 0) return;
  const char* text = nullptr;
  PetscErrorMessage(code, &text, nullptr);
  throw std::runtime_error(std::string("PETSc: ") + call + " failed: " + (text ? text : std::to_string(int(code))));
}

bool petsc_started = false;

// PETSc on the MPI that the program began (ranks::start), once per process; the program calls
// photometria_petsc_gmres_finalize before it ends MPI.
void start_petsc() {
  if (petsc_started) return;
  check(PetscInitializeNoArguments(), "PetscInitialize");
  check(PetscPushErrorHandler(PetscReturnErrorHandler, nullptr), "PetscPushErrorHandler");
  petsc_started = true;
}

// K = I − diag(ρ) F on this rank's rows; PETSc's index p is patch patch_of_index[p].
struct Operator {
  const RowBlock* block = nullptr;
  const Eigen::VectorXd* rho = nullptr;
  const std::vector<int>* patch_of_index = nullptr;
  VecScatter to_all = nullptr;  // x onto every rank
  Vec gathered = nullptr;       // x, whole, in PETSc's order
  Eigen::VectorXd x;            // x, whole, in patch order
};

// Every rank gets all of v, in patch order, in out.
PetscErrorCode gather(Operator& op, Vec v, Eigen::VectorXd& out) {
  PetscFunctionBeginUser;
  PetscCall(VecScatterBegin(op.to_all, v, op.gathered, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(op.to_all, v, op.gathered, INSERT_VALUES, SCATTER_FORWARD));
  const PetscScalar* a = nullptr;
  PetscCall(VecGetArrayRead(op.gathered, &a));
  const std::vector<int>& patch = *op.patch_of_index;
  out.resize(Eigen::Index(patch.size()));
  for (size_t p = 0; p < patch.size(); ++p) out[patch[p]] = a[p];
  PetscCall(VecRestoreArrayRead(op.gathered, &a));
  PetscFunctionReturn(0);
}

// y = K x, this rank's rows (the shell matrix's MatMult).
PetscErrorCode apply_operator(Mat A, Vec x, Vec y) {
  PetscFunctionBeginUser;
  Operator* op = nullptr;
  PetscCall(MatShellGetContext(A, &op));
  PetscCall(gather(*op, x, op->x));
  PetscScalar* out = nullptr;
  PetscCall(VecGetArray(y, &out));
  const RowBlock& block = *op->block;
  const Eigen::VectorXd& rho = *op->rho;
  const Eigen::VectorXd& xs = op->x;
#pragma omp parallel for schedule(static)
  for (size_t k = 0; k < block.rows.size(); ++k) {
    const int i = block.rows[k];
    out[k] = xs[i] - rho[i] * block.F.row(Eigen::Index(k)).dot(xs);
  }
  PetscCall(VecRestoreArray(y, &out));
  PetscFunctionReturn(0);
}

// The solve of distributed_gmres_channel (distributed/distributed_gmres.h).
ChannelResult solve(const PetscGmresRequest& request) {
  const RowBlock& block = *request.block;
  const Eigen::VectorXd &E = *request.E, &rho = *request.rho, &H = *request.H;
  const SolverOptions& options = *request.options;
  const std::vector<int>& patch_of_index = *request.patch_of_index;
  Eigen::VectorXd& B = *request.B;
  const int restart = request.restart;
  start_petsc();
  const Eigen::Index n = E.size();
  const PetscInt local = PetscInt(block.rows.size());

  Operator op;
  op.block = &block;
  op.rho = &rho;
  op.patch_of_index = &patch_of_index;
  Mat K = nullptr;
  Vec x = nullptr, b = nullptr;
  KSP ksp = nullptr;
  // Everything PETSc made, destroyed on every path out (the calls accept null handles).
  struct Cleanup {
    Mat& K;
    Vec &x, &b;
    KSP& ksp;
    Operator& op;
    ~Cleanup() {
      KSPDestroy(&ksp);
      VecScatterDestroy(&op.to_all);
      VecDestroy(&op.gathered);
      VecDestroy(&x);
      VecDestroy(&b);
      MatDestroy(&K);
    }
  } cleanup{K, x, b, ksp, op};

  check(MatCreateShell(PETSC_COMM_WORLD, local, local, PetscInt(n), PetscInt(n), &op, &K), "MatCreateShell");
  check(MatShellSetOperation(K, MATOP_MULT, reinterpret_cast<void (*)(void)>(apply_operator)), "MatShellSetOperation");
  check(MatCreateVecs(K, &x, &b), "MatCreateVecs");
  check(VecScatterCreateToAll(x, &op.to_all, &op.gathered), "VecScatterCreateToAll");
  {
    PetscScalar *xb = nullptr, *bb = nullptr;
    check(VecGetArray(x, &xb), "VecGetArray");
    check(VecGetArray(b, &bb), "VecGetArray");
    for (size_t k = 0; k < block.rows.size(); ++k) {
      const int i = block.rows[k];
      bb[k] = E[i] + rho[i] * H[i];
      xb[k] = E[i];  // first guess: emission only, as the other solvers
    }
    check(VecRestoreArray(b, &bb), "VecRestoreArray");
    check(VecRestoreArray(x, &xb), "VecRestoreArray");
  }
  auto relative_residual = [&] { return request.relative_residual(B); };
  check(gather(op, x, B), "gather");
  ChannelResult result;
  result.iterations = 1;
  result.residual = relative_residual();
  if (result.residual <= options.tolerance) {
    result.converged = true;
    return result;
  }

  check(KSPCreate(PETSC_COMM_WORLD, &ksp), "KSPCreate");
  check(KSPSetOperators(ksp, K, K), "KSPSetOperators");
  check(KSPSetType(ksp, KSPGMRES), "KSPSetType");
  check(KSPGMRESSetRestart(ksp, PetscInt(restart)), "KSPGMRESSetRestart");
  check(KSPGMRESSetOrthogonalization(ksp, KSPGMRESModifiedGramSchmidtOrthogonalization),
        "KSPGMRESSetOrthogonalization");
  PC pc = nullptr;
  check(KSPGetPC(ksp, &pc), "KSPGetPC");
  check(PCSetType(pc, PCNONE), "PCSetType");
  check(KSPSetInitialGuessNonzero(ksp, PETSC_TRUE), "KSPSetInitialGuessNonzero");
  double rtol = options.tolerance;
  int restarts = 0;
  while (true) {
    const int left = options.max_iterations - result.iterations;
    if (left <= 0) break;
    check(KSPSetTolerances(ksp, rtol, 0.0, PETSC_DEFAULT, PetscInt(left)), "KSPSetTolerances");
    check(KSPSolve(ksp, b, x), "KSPSolve");
    PetscInt steps = 0;
    check(KSPGetIterationNumber(ksp, &steps), "KSPGetIterationNumber");
    check(gather(op, x, B), "gather");
    result.iterations += int(steps) + 1;
    result.residual = relative_residual();
    if (result.residual <= options.tolerance) {
      result.converged = true;
      break;
    }
    KSPConvergedReason reason;
    check(KSPGetConvergedReason(ksp, &reason), "KSPGetConvergedReason");
    // PETSc met its test but ours is not met (rounding in GMRES's residual estimate): continue
    // from B, ten times tighter, a few times at most; anything else is the end.
    if (reason <= 0 || ++restarts > 4 || steps == 0) break;
    rtol *= 0.1;
  }
  return result;
}

}  // namespace

}  // namespace photometria

extern "C" {

__attribute__((visibility("default"))) int photometria_petsc_gmres_solve(photometria::PetscGmresRequest* request) {
  try {
    *request->result = photometria::solve(*request);
    return 0;
  } catch (const std::exception& e) { *request->error = e.what(); } catch (...) {
    *request->error = "unknown error";
  }
  return 1;
}

__attribute__((visibility("default"))) void photometria_petsc_gmres_finalize() {
  if (photometria::petsc_started) PetscFinalize();
  photometria::petsc_started = false;
}

}  // extern "C"
