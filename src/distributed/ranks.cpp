// The ranks of an MPI run, or one process (ranks.h).
#include "distributed/ranks.h"

#include <cstdlib>
#include <stdexcept>
#include <tuple>
#include <utility>

#include "util/error.h"

#ifdef PHOTOMETRIA_HAVE_MPI
#include <mpi.h>
#endif

namespace photometria::ranks {

#ifdef PHOTOMETRIA_HAVE_MPI
namespace {

bool launched_by_mpi() {
  for (const char* variable : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"})
    if (std::getenv(variable)) return true;
  return false;
}

// This rank's failure as (exit code, message); code 4 for what is not a photometria::Error.
std::pair<int, std::string> describe(const std::exception_ptr& failure) {
  try {
    std::rethrow_exception(failure);
  } catch (const Error& e) { return {e.exit_code(), e.what()}; } catch (const std::exception& e) {
    return {4, e.what()};
  } catch (...) { return {4, "unknown error"}; }
}

std::vector<std::function<void()>>& stop_hooks() {
  static std::vector<std::function<void()>> hooks;
  return hooks;
}

bool started = false;
int world_rank = 0, world_size = 1, machine_size = 1;

}  // namespace

void start(int* argc, char*** argv) {
  if (started || !launched_by_mpi()) return;
  int provided = 0;
  // FUNNELED: only the main thread calls MPI; the fill's OpenMP threads never do.
  if (MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS)
    throw_io("MPI: the launcher's MPI library could not start");
  started = true;
  MPI_Comm_rank(MPI_COMM_WORLD, &world_rank);
  MPI_Comm_size(MPI_COMM_WORLD, &world_size);
  MPI_Comm machine;
  MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, world_rank, MPI_INFO_NULL, &machine);
  MPI_Comm_size(machine, &machine_size);
  MPI_Comm_free(&machine);
}

void before_stop(std::function<void()> fn) { stop_hooks().push_back(std::move(fn)); }

void stop() {
  if (!started) return;
  started = false;
  for (auto it = stop_hooks().rbegin(); it != stop_hooks().rend(); ++it) (*it)();
  stop_hooks().clear();
  MPI_Finalize();
}

void abort_all(int code) {
  if (started && world_size > 1) MPI_Abort(MPI_COMM_WORLD, code);
  std::exit(code);
}

int rank() { return world_rank; }
int size() { return world_size; }
int local_size() { return machine_size; }

std::string library() {
  if (!started) return "none";
  char version[MPI_MAX_LIBRARY_VERSION_STRING];
  int length = 0;
  MPI_Get_library_version(version, &length);
  std::string s(version, size_t(length));
  const size_t end = s.find_first_of(",\n");  // "Open MPI v4.1.4, package: ..." -> its first part
  return end == std::string::npos ? s : s.substr(0, end);
}

void sum(std::vector<double>& values) {
  if (world_size > 1)
    MPI_Allreduce(MPI_IN_PLACE, values.data(), int(values.size()), MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
}

void sum(std::vector<long long>& values) {
  if (world_size > 1)
    MPI_Allreduce(MPI_IN_PLACE, values.data(), int(values.size()), MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
}

double max(double value) {
  if (world_size > 1) MPI_Allreduce(MPI_IN_PLACE, &value, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  return value;
}

double min(double value) {
  if (world_size > 1) MPI_Allreduce(MPI_IN_PLACE, &value, 1, MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
  return value;
}

std::vector<double> all_values(double value) {
  std::vector<double> out(size_t(world_size), value);
  if (world_size > 1) MPI_Allgather(&value, 1, MPI_DOUBLE, out.data(), 1, MPI_DOUBLE, MPI_COMM_WORLD);
  return out;
}

void broadcast(std::string& text, int root) {
  if (world_size <= 1) return;
  unsigned long long length = text.size();
  MPI_Bcast(&length, 1, MPI_UNSIGNED_LONG_LONG, root, MPI_COMM_WORLD);
  text.resize(size_t(length));
  MPI_Bcast(text.data(), int(length), MPI_CHAR, root, MPI_COMM_WORLD);
}

void agree(const std::exception_ptr& failure) {
  if (world_size <= 1) {
    if (failure) std::rethrow_exception(failure);
    return;
  }
  int first = failure ? world_rank : world_size;
  MPI_Allreduce(MPI_IN_PLACE, &first, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  if (first == world_size) return;
  int code = 0;
  std::string message;
  if (world_rank == first) std::tie(code, message) = describe(failure);
  int length = int(message.size());
  MPI_Bcast(&code, 1, MPI_INT, first, MPI_COMM_WORLD);
  MPI_Bcast(&length, 1, MPI_INT, first, MPI_COMM_WORLD);
  message.resize(size_t(length));
  MPI_Bcast(message.data(), length, MPI_CHAR, first, MPI_COMM_WORLD);
  throw SharedError(code, first == 0 ? message : "rank " + std::to_string(first) + ": " + message);
}

#else  // one process

void start(int*, char***) {}
void stop() {}
void before_stop(std::function<void()>) {}  // nothing starts on MPI without it
void abort_all(int code) { std::exit(code); }
int rank() { return 0; }
int size() { return 1; }
int local_size() { return 1; }
std::string library() { return "none"; }
void sum(std::vector<double>&) {}
void sum(std::vector<long long>&) {}
double max(double value) { return value; }
double min(double value) { return value; }
std::vector<double> all_values(double value) { return {value}; }
void broadcast(std::string&, int) {}
void agree(const std::exception_ptr& failure) {
  if (failure) std::rethrow_exception(failure);
}

#endif

}  // namespace photometria::ranks
