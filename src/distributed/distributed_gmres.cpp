// GMRES on MPI ranks: the program's side. The PETSc solve lives in a module loaded on first use
// (distributed/petsc/petsc_gmres_module.h says why); this file finds and loads it.
#include "distributed/distributed_gmres.h"

#include <dlfcn.h>
#include <unistd.h>

#include <climits>
#include <mutex>
#include <stdexcept>
#include <string>

#include "distributed/petsc/petsc_gmres_module.h"
#include "distributed/ranks.h"

namespace photometria {

namespace {

// The module's entry points, or why there are none.
struct PetscModule {
  PetscGmresSolve solve = nullptr;
  PetscGmresFinalize finalize = nullptr;
  std::string why_not;
};

// The module beside the executable (CMake writes both to the same directory).
std::string module_path() {
  char exe[PATH_MAX];
  const ssize_t n = ::readlink("/proc/self/exe", exe, sizeof exe - 1);
  if (n <= 0) return kPetscModuleFile;  // the loader's search path
  const std::string path(exe, size_t(n));
  const size_t slash = path.rfind('/');
  return (slash == std::string::npos ? std::string() : path.substr(0, slash + 1)) + kPetscModuleFile;
}

const PetscModule& petsc_module() {
  static PetscModule module;
  static std::once_flag once;
  std::call_once(once, [] {
#if PHOTOMETRIA_HAVE_PETSC
    const std::string path = module_path();
    void* handle = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);  // kept loaded until the process ends
    if (!handle) {
      const char* why = ::dlerror();
      module.why_not = "cannot load the PETSc module: " + std::string(why ? why : path);
      return;
    }
    module.solve = reinterpret_cast<PetscGmresSolve>(::dlsym(handle, kPetscGmresSolveSymbol));
    module.finalize = reinterpret_cast<PetscGmresFinalize>(::dlsym(handle, kPetscGmresFinalizeSymbol));
    if (!module.solve || !module.finalize) {
      module.solve = nullptr;
      module.why_not = path + " lacks " + kPetscGmresSolveSymbol;
      return;
    }
    // PETSc, once started on the ranks' MPI, must end before it.
    ranks::before_stop([finalize = module.finalize] { finalize(); });
#else
    module.why_not = "this build has no PETSc (install petsc-dev and rebuild)";
#endif
  });
  return module;
}

}  // namespace

bool distributed_gmres_available() { return petsc_module().solve != nullptr; }

std::string distributed_gmres_unavailable_reason() { return petsc_module().why_not; }

ChannelResult distributed_gmres_channel(const RowBlock& block, const std::vector<std::vector<int>>& parts,
                                        const Eigen::VectorXd& E, const Eigen::VectorXd& rho, const Eigen::VectorXd& H,
                                        const SolverOptions& options, Eigen::VectorXd& B, int restart) {
  const PetscModule& module = petsc_module();
  if (!module.solve) throw std::runtime_error("distributed GMRES: " + module.why_not);
  std::vector<int> patch_of_index;
  for (const std::vector<int>& part : parts) patch_of_index.insert(patch_of_index.end(), part.begin(), part.end());
  if (Eigen::Index(patch_of_index.size()) != E.size())
    throw std::invalid_argument("distributed_gmres: parts do not cover F");
  // The common residual (solver.h) with every rank's rows, from B whole on every rank.
  const SumOverProcesses sum = [](std::vector<double>& v) { ranks::sum(v); };
  ChannelResult result;
  std::string error;
  PetscGmresRequest request;
  request.block = &block;
  request.patch_of_index = &patch_of_index;
  request.E = &E;
  request.rho = &rho;
  request.H = &H;
  request.options = &options;
  request.restart = restart;
  request.relative_residual = [&](const Eigen::VectorXd& x) {
    return block_relative_residual(block, E, rho, H, x, sum);
  };
  request.B = &B;
  request.result = &result;
  request.error = &error;
  if (module.solve(&request) != 0) throw std::runtime_error("distributed GMRES: " + error);
  return result;
}

}  // namespace photometria
