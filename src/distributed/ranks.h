// The processes of one run: the ranks of an MPI job (`mpirun -np R photometria ...`), or this
// process alone.
//
// MPI (the MPI-3.1 standard; Open MPI on Debian) is started only when the build has it
// (PHOTOMETRIA_HAVE_MPI, CMake option PHOTOMETRIA_MPI) and the process was started by an MPI
// launcher, which says so in its environment (OMPI_COMM_WORLD_SIZE, PMI_SIZE or PMIX_RANK). A
// plain run never initialises MPI: it costs nothing and behaves as a build without it, one rank.
//
// Every collective below must be called by every rank, in the same order; on one rank each is
// the identity. Errors: a rank that fails where the others may go on (writing, a full disk)
// reports it through agree(), which turns one rank's failure into the same Error on every rank,
// so that no rank waits forever in a collective the failed one never reaches.
#pragma once

#include <exception>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace photometria {

namespace ranks {

// Starts MPI when launched by an MPI launcher (see above); call once, first thing in main().
// Throws Error(Io) when the launcher's MPI cannot start.
void start(int* argc, char*** argv);
// Ends MPI (MPI_Finalize) if start() began it; call once, last thing in main().
void stop();
// Registers what must end before MPI does (a library started on MPI: PETSc); stop() calls each,
// the latest first, before MPI_Finalize.
void before_stop(std::function<void()> fn);
// Ends every rank of the job at once (MPI_Abort) with exit status `code`; on one rank, exit().
[[noreturn]] void abort_all(int code);

int rank();  // this process, 0 .. size() - 1
int size();  // R, 1 without MPI
inline bool distributed() { return size() > 1; }
inline bool is_root() { return rank() == 0; }
int local_size();       // ranks on this machine (sharing its cores)
std::string library();  // the MPI library's version line, or "none"

// Element-wise sums over the ranks, in place (every rank gets the result).
void sum(std::vector<double>& values);
void sum(std::vector<long long>& values);
double max(double value);
double min(double value);
// Every rank's `value`, indexed by rank.
std::vector<double> all_values(double value);
// Rank `root`'s `text` on every rank.
void broadcast(std::string& text, int root = 0);

// What agree() throws on every rank at once: the lowest failing rank's error. main() prints it on
// rank 0 only and every rank exits with exit_code(), with no rank left waiting.
class SharedError : public std::runtime_error {
 public:
  SharedError(int exit_code, const std::string& message) : std::runtime_error(message), exit_code_(exit_code) {}
  int exit_code() const { return exit_code_; }  // as Error's (1-3), 4 for an internal error

 private:
  int exit_code_;
};

// Error agreement, a collective: `failure` is this rank's error (null when it succeeded). When any
// rank failed, every rank throws SharedError: the lowest failing rank's message (its exit code, 4
// for exceptions that are not a photometria::Error), prefixed "rank K: " unless K = 0. On one rank
// the failure itself is rethrown. Returns when no rank failed.
void agree(const std::exception_ptr& failure);

}  // namespace ranks

}  // namespace photometria
