// Atomic output: write to a temporary file beside the target, rename over it on success.
//
// A failed or interrupted run never leaves a half-written result: until commit() the target is
// untouched, and the destructor removes the temporary file if commit() was not reached. When the
// process is stopped by SIGINT, SIGTERM or SIGHUP, a signal handler (installed by the first
// AtomicOutput, only for signals still at their default action) unlinks every live temporary
// file and then lets the signal end the process as it would have (exit status "killed by
// signal"). The live temporary paths are kept in a fixed-size table (64 entries of up to 4095
// bytes) so that the handler needs nothing but unlink(2), which is async-signal-safe; a path
// that does not fit is still written atomically, only not cleaned up on a signal.
#pragma once

#include <string>

namespace photometria {

class AtomicOutput {
 public:
  // Checks that the target's folder exists and is writable (creating the temporary file
  // "<target>.tmp-<pid>"); throws Error(Io) naming the path.
  explicit AtomicOutput(std::string target);
  ~AtomicOutput();
  AtomicOutput(const AtomicOutput&) = delete;
  AtomicOutput& operator=(const AtomicOutput&) = delete;

  const std::string& temp_path() const { return temp_; }
  const std::string& target() const { return target_; }
  // Renames the temporary file onto the target; throws Error(Io) on failure.
  void commit();

 private:
  std::string target_, temp_;
  bool committed_ = false;
  int slot_ = -1;  // entry in the signal-cleanup table, -1 when not registered
};

// Number of temporary files the signal handler would remove right now (for tests).
int live_temporary_files();

}  // namespace photometria
