#include "io/atomic_file.h"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
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

}  // namespace

int live_temporary_files() {
  int n = 0;
  for (int i = 0; i < kSlots; ++i) n += g_state[i].load() == 2;
  return n;
}

AtomicOutput::AtomicOutput(std::string target) : target_(std::move(target)) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::path(target_).has_parent_path() ? fs::path(target_).parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw_io("cannot write '" + target_ + "': folder '" + dir.string() + "' does not exist");
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

void AtomicOutput::commit() {
  if (std::rename(temp_.c_str(), target_.c_str()) != 0)
    throw_io("cannot rename '" + temp_ + "' to '" + target_ + "': " + std::strerror(errno));
  committed_ = true;
}

}  // namespace photometria
