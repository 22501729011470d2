#include "io/atomic_file.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>

#include "util/error.h"

namespace photometria {
namespace {

// The registry of live temporary files, readable from a signal handler: fixed storage, and
// lock-free atomic flags (std::atomic<int> is lock-free on every platform we build for).
constexpr int kSlots = 64;
constexpr size_t kPathBytes = 4096;
char g_paths[kSlots][kPathBytes];
std::atomic<int> g_state[kSlots];  // 0 free, 1 being filled or emptied, 2 live (handler unlinks)
static_assert(std::atomic<int>::is_always_lock_free, "the signal handler needs lock-free atomics");

constexpr int kSignals[] = {SIGINT, SIGTERM, SIGHUP};

extern "C" void remove_temporaries_and_die(int sig) {
  const int saved_errno = errno;
  for (int i = 0; i < kSlots; ++i)
    if (g_state[i].load() == 2) ::unlink(g_paths[i]);
  // Then end the process the way the signal would have: default action, raised again.
  struct sigaction dfl {};
  dfl.sa_handler = SIG_DFL;
  sigemptyset(&dfl.sa_mask);
  ::sigaction(sig, &dfl, nullptr);
  errno = saved_errno;
  ::raise(sig);
}

void install_handlers() {
  static std::once_flag once;
  std::call_once(once, [] {
    for (int sig : kSignals) {
      struct sigaction old {};
      if (::sigaction(sig, nullptr, &old) != 0 || old.sa_handler != SIG_DFL) continue;  // ignored or handled: leave it
      struct sigaction sa {};
      sa.sa_handler = remove_temporaries_and_die;
      sigemptyset(&sa.sa_mask);
      for (int other : kSignals) sigaddset(&sa.sa_mask, other);  // one cleanup at a time
      ::sigaction(sig, &sa, nullptr);
    }
  });
}

int register_temporary(const std::string& path) {
  if (path.size() >= kPathBytes) return -1;
  for (int i = 0; i < kSlots; ++i) {
    int expected = 0;
    if (!g_state[i].compare_exchange_strong(expected, 1)) continue;
    std::memcpy(g_paths[i], path.c_str(), path.size() + 1);
    g_state[i].store(2);
    return i;
  }
  return -1;  // table full: still atomic, only not removed on a signal
}

void unregister_temporary(int slot) {
  if (slot < 0) return;
  g_state[slot].store(1);
  g_paths[slot][0] = '\0';
  g_state[slot].store(0);
}

// Why a write failed, from errno right after it: the write errors by name, anything else (errno
// overwritten or never set by the stream) as the likely cause.
std::string write_failure_reason() {
  const int e = errno;
  switch (e) {
    case ENOSPC:
    case EFBIG:
    case EIO:
    case EDQUOT:
    case EROFS:
    case EPIPE:
    case EBADF: return std::strerror(e);
    default: return "write failed (disk full?)";
  }
}

}  // namespace

void sync_file(const std::string& path, const std::string& name) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw_io("cannot write '" + name + "': " + std::strerror(errno));
  const int rc = ::fsync(fd);
  const int e = errno;
  ::close(fd);
  if (rc != 0 && e != EINVAL)
    throw_io("cannot write '" + name + "': " + std::strerror(e));  // EINVAL: cannot sync (a pipe)
}

void finish_standard_output() {
  errno = 0;
  std::cout.flush();
  const bool stream_ok = static_cast<bool>(std::cout);
  if (std::fflush(stdout) != 0 || !stream_ok || std::ferror(stdout))
    throw_io("cannot write standard output: " + write_failure_reason());
  struct stat st {};
  if (::fstat(STDOUT_FILENO, &st) == 0 && S_ISREG(st.st_mode) && ::fsync(STDOUT_FILENO) != 0 && errno != EINVAL)
    throw_io(std::string("cannot write standard output: ") + std::strerror(errno));
}

int live_temporary_files() {
  int n = 0;
  for (int i = 0; i < kSlots; ++i) n += g_state[i].load() == 2;
  return n;
}

AtomicOutput::AtomicOutput(std::string target) : target_(std::move(target)) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::path(target_).has_parent_path() ? fs::path(target_).parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw_io("cannot write '" + target_ + "': folder '" + dir.string() + "' does not exist");
  if (fs::is_directory(target_, ec)) throw_io("cannot write '" + target_ + "': it is a folder");
  temp_ = target_ + ".tmp-" + std::to_string(::getpid());
  install_handlers();
  // Registered before the file exists, so that there is no moment when it exists unregistered.
  slot_ = register_temporary(temp_);
  // Probe now, before any long computation, that the folder takes a new file.
  std::ofstream probe(temp_);
  if (!probe) {
    const std::string reason = std::strerror(errno);
    unregister_temporary(slot_);
    throw_io("cannot write '" + target_ + "': " + reason);
  }
  probe.close();
}

AtomicOutput::~AtomicOutput() {
  if (!committed_) std::remove(temp_.c_str());
  unregister_temporary(slot_);
}

std::ofstream& AtomicOutput::stream() {
  if (!stream_opened_) {
    stream_opened_ = true;
    errno = 0;
    stream_.open(temp_, std::ios::binary | std::ios::trunc);
    if (!stream_) throw_io("cannot write '" + target_ + "': " + std::strerror(errno ? errno : EIO));
  }
  return stream_;
}

void AtomicOutput::check_stream() {
  if (stream_opened_ && !stream_) throw_io("cannot write '" + target_ + "': " + write_failure_reason());
}

void AtomicOutput::finish() {
  if (stream_opened_ && stream_.is_open()) {
    errno = 0;
    if (stream_) stream_.flush();
    check_stream();
    stream_.close();  // the last buffered bytes go out here
    check_stream();
  }
  sync_file(temp_, target_);
}

void AtomicOutput::commit() {
  finish();
  if (std::rename(temp_.c_str(), target_.c_str()) != 0)
    throw_io("cannot rename '" + temp_ + "' to '" + target_ + "': " + std::strerror(errno));
  committed_ = true;
}

}  // namespace photometria
