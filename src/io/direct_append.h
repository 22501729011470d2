// Appending a large output to an AtomicOutput's temporary file past the page cache.
//
// Why: a buffered write copies every byte into the page cache first, and on a VM whose free
// memory is handed back to the host (the project's Firecracker VM with DAMON reclaim) each fresh
// page-cache page costs about 2 ms per MB: a 300 MB write(2) took 0.7 s there, the disk itself
// 0.25 s (docs/performance.md "Writing the matrix"). O_DIRECT writes go from the program's
// buffer to the disk, and a second thread writes one buffer while the caller fills the next, so
// the disk works while the next rows are formatted.
//
// How: the bytes already in the stream are flushed; the file is continued from the last
// 4 KiB boundary before its end (that partial block is read back into the first buffer), in
// 8 MiB buffers aligned to 4 KiB, each written with pwrite(2) on an O_DIRECT descriptor at its
// (aligned) offset. The last, partial block goes through an ordinary descriptor. Where the file
// system refuses O_DIRECT (tmpfs, some network file systems: EINVAL at open or at the first
// write), the same buffers are written through the ordinary descriptor instead: the bytes are the
// same, only the page cache is used. After finish() the stream is positioned at the end, so a
// writer can add a trailer through it. commit() still fsyncs the whole file, but the writer
// thread has called fdatasync after every 64 MiB, so that the disk flushes while the rows are
// formatted (the 717 MB CSV of the 6,144-face cube: 1.63 s median of five against 1.93 s).
#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "io/atomic_file.h"

namespace photometria {

class DirectAppender {
 public:
  // `out` must outlive this object and not be written through its stream() until finish().
  // `direct` false: ordinary writes only (the fallback, for tests). Throws Error(Io) naming the
  // target when the file cannot be opened or read back.
  explicit DirectAppender(AtomicOutput& out, bool direct = true);
  ~DirectAppender();  // stops the writer thread (without finish(), the file is left incomplete)
  DirectAppender(const DirectAppender&) = delete;
  DirectAppender& operator=(const DirectAppender&) = delete;

  // Appends n bytes. Throws Error(Io) naming the target as soon as an earlier write failed.
  void append(const char* data, size_t n);
  // Writes what is left, waits for every write, and positions out.stream() at the end. Throws
  // Error(Io) naming the target when any write failed (a full disk, a file size limit).
  void finish();

  bool direct() const { return direct_fd_ >= 0; }  // false once O_DIRECT was refused

 private:
  static constexpr size_t kAlign = 4096;
  static constexpr size_t kBufferBytes = size_t(8) << 20;
  static constexpr size_t kSyncEveryBytes = size_t(64) << 20;  // fdatasync from the writer thread
  size_t unsynced_ = 0;                                        // written since (writer thread only)
  struct Buffer {
    char* data = nullptr;
    size_t used = 0;
    long long offset = 0;  // file offset of data[0], a multiple of kAlign
  };
  void submit();                                     // hands the current buffer to the writer thread, takes a free one
  void writer_loop();                                // the writer thread
  void write_buffer(const Buffer& b, size_t bytes);  // pwrite, O_DIRECT where it can
  void throw_if_failed();

  AtomicOutput& out_;
  int direct_fd_ = -1, plain_fd_ = -1;
  std::vector<char*> blocks_;  // the aligned buffers (three: one filling, two writing or free)
  Buffer current_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<Buffer> full_;  // waiting for the writer thread
  std::vector<char*> free_;  // written, ready to fill
  bool stopping_ = false, writing_ = false;
  int error_ = 0;  // the first errno of a failed write
  std::thread writer_;
  bool finished_ = false;
};

}  // namespace photometria
