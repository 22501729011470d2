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
//
// A result is only renamed into place once its bytes are known to be on the disk: commit()
// flushes and closes the stream (a short write, e.g. a full disk or a `ulimit -f`, fails there),
// then fsync(2)s the temporary file (a file system that reports lost writes late fails there)
// and only then renames it. On any failure the target keeps its earlier contents and the
// temporary file is removed. Writers that write the temporary file themselves (VTK, gnuplot)
// check their own error reporting first; commit() still does the fsync.
#pragma once

#include <fstream>
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
  // The temporary file as a binary stream, opened (truncated) on the first call. Writers put
  // their bytes here and leave the error checking to commit().
  std::ofstream& stream();
  // Throws Error(Io) "cannot write '<target>': <reason>" when the stream() went bad (a write,
  // flush or close failed). Long writers call it between blocks to stop early.
  void check_stream();
  // Closes stream() and checks it, and fsyncs the temporary file: after it, the temporary file's
  // bytes are on the disk (for a file another program reads next). Throws Error(Io).
  void finish();
  // finish(), then renames the temporary file onto the target; throws Error(Io) naming the
  // target on failure (the target is then untouched).
  void commit();

 private:
  std::string target_, temp_;
  std::ofstream stream_;
  bool stream_opened_ = false;
  bool committed_ = false;
  int slot_ = -1;  // entry in the signal-cleanup table, -1 when not registered
};

// Number of temporary files the signal handler would remove right now (for tests).
int live_temporary_files();

// fsync(2)s the file at `path`; throws Error(Io) "cannot write '<name>': <reason>" on failure.
void sync_file(const std::string& path, const std::string& name);

// Flushes standard output and checks that everything printed on it was written (and, when it
// is a regular file, fsyncs it); throws Error(Io) "cannot write standard output: <reason>".
// Called once, after a command has printed its results.
void finish_standard_output();

}  // namespace photometria
