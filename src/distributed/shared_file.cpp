// Every rank's pieces of one file at their offsets (shared_file.h).
#include "distributed/shared_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <exception>
#include <memory>

#include "distributed/ranks.h"
#include "util/error.h"

#ifdef PHOTOMETRIA_HAVE_MPI
#include <mpi.h>
#endif

namespace photometria {

namespace {

// At most this many bytes per call (MPI counts are ints; pwrite may write less than asked).
constexpr long long kChunk = 1LL << 30;

#ifdef PHOTOMETRIA_HAVE_MPI
std::string mpi_error(int code) {
  char text[MPI_MAX_ERROR_STRING];
  int length = 0;
  MPI_Error_string(code, text, &length);
  return std::string(text, size_t(length));
}
#endif

// The file open for writing on this rank: MPI-IO over the ranks when distributed, else a
// descriptor. Its calls throw Error(Io) naming the target.
class PieceFile {
 public:
  PieceFile(const std::string& path, const std::string& name) : name_(name) {
#ifdef PHOTOMETRIA_HAVE_MPI
    if (ranks::distributed()) {
      mpi_ = true;
      const int rc = MPI_File_open(MPI_COMM_WORLD, path.c_str(), MPI_MODE_WRONLY, MPI_INFO_NULL, &file_);
      if (rc != MPI_SUCCESS) fail(mpi_error(rc));
      open_ = true;
      return;
    }
#endif
    fd_ = ::open(path.c_str(), O_WRONLY);
    if (fd_ < 0) fail(std::strerror(errno));
  }
  ~PieceFile() {
    if (fd_ >= 0) ::close(fd_);
  }
  PieceFile(const PieceFile&) = delete;
  PieceFile& operator=(const PieceFile&) = delete;

  void write_at(long long offset, const std::string& bytes) {
    for (long long done = 0; done < (long long)bytes.size();) {
      const long long n = std::min<long long>(kChunk, (long long)bytes.size() - done);
#ifdef PHOTOMETRIA_HAVE_MPI
      if (mpi_) {
        MPI_Status status;
        const int rc =
            MPI_File_write_at(file_, MPI_Offset(offset + done), bytes.data() + done, int(n), MPI_CHAR, &status);
        if (rc != MPI_SUCCESS) fail(mpi_error(rc));
        done += n;
        continue;
      }
#endif
      const ssize_t w = ::pwrite(fd_, bytes.data() + done, size_t(n), off_t(offset + done));
      if (w < 0) {
        if (errno == EINTR) continue;
        fail(std::strerror(errno));
      }
      done += w;
    }
  }

  // Collective under MPI: every rank calls it once, whatever failed before; throws afterwards.
  void sync_and_close() {
#ifdef PHOTOMETRIA_HAVE_MPI
    if (mpi_) {
      if (!open_) return;
      open_ = false;
      const int synced = MPI_File_sync(file_);
      const int closed = MPI_File_close(&file_);
      if (synced != MPI_SUCCESS) fail(mpi_error(synced));
      if (closed != MPI_SUCCESS) fail(mpi_error(closed));
      return;
    }
#endif
    if (::fsync(fd_) != 0) fail(std::strerror(errno));
    const int fd = fd_;
    fd_ = -1;
    if (::close(fd) != 0) fail(std::strerror(errno));
  }

 private:
  [[noreturn]] void fail(const std::string& reason) const { throw_io("cannot write '" + name_ + "': " + reason); }
  std::string name_;
  int fd_ = -1;
#ifdef PHOTOMETRIA_HAVE_MPI
  bool mpi_ = false, open_ = false;
  MPI_File file_ = MPI_FILE_NULL;
#endif
};

}  // namespace

void write_pieces(const std::string& path, const std::string& name, const std::string& head,
                  const std::vector<std::pair<int, const std::string*>>& mine, int count, const std::string& tail) {
  std::vector<long long> length(size_t(std::max(count, 0)), 0);
  for (const auto& [k, bytes] : mine) length[size_t(k)] = (long long)bytes->size();
  ranks::sum(length);
  std::vector<long long> offset(length.size());
  long long at = (long long)head.size();
  for (size_t k = 0; k < length.size(); ++k) {
    offset[k] = at;
    at += length[k];
  }
  // Opening is collective: it succeeds or fails on every rank, which agree() confirms.
  std::exception_ptr failure;
  std::unique_ptr<PieceFile> file;
  try {
    file = std::make_unique<PieceFile>(path, name);
  } catch (...) { failure = std::current_exception(); }
  ranks::agree(failure);
  try {
    if (ranks::is_root()) file->write_at(0, head);
    for (const auto& [k, bytes] : mine) file->write_at(offset[size_t(k)], *bytes);
    if (ranks::is_root()) file->write_at(at, tail);
  } catch (...) { failure = std::current_exception(); }
  try {
    file->sync_and_close();  // on every rank, even after a failed write: it is collective
  } catch (...) {
    if (!failure) failure = std::current_exception();
  }
  ranks::agree(failure);
}

}  // namespace photometria
