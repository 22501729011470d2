// Appending past the page cache (direct_append.h).
#include "io/direct_append.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

#include "util/error.h"

namespace photometria {

DirectAppender::DirectAppender(AtomicOutput& out, bool direct) : out_(out) {
  std::ofstream& stream = out_.stream();
  stream.flush();
  out_.check_stream();
  const long long end = static_cast<long long>(stream.tellp());
  const std::string cannot = "cannot write '" + out_.target() + "': ";
  plain_fd_ = ::open(out_.temp_path().c_str(), O_RDWR | O_CLOEXEC);
  if (plain_fd_ < 0 || end < 0) throw_io(cannot + std::strerror(plain_fd_ < 0 ? errno : EIO));
  if (direct) direct_fd_ = ::open(out_.temp_path().c_str(), O_WRONLY | O_DIRECT | O_CLOEXEC);
  for (int k = 0; k < 3; ++k) {
    char* block = static_cast<char*>(std::aligned_alloc(kAlign, kBufferBytes));
    if (!block) throw std::bad_alloc();
    blocks_.push_back(block);
  }
  free_.assign(blocks_.begin() + 1, blocks_.end());
  current_.data = blocks_[0];
  // Continue from the last aligned offset: the partial block before the end is read back.
  current_.offset = end - end % static_cast<long long>(kAlign);
  current_.used = static_cast<size_t>(end - current_.offset);
  if (current_.used > 0 &&
      ::pread(plain_fd_, current_.data, current_.used, current_.offset) != static_cast<ssize_t>(current_.used))
    throw_io(cannot + "cannot read back its last block");
  writer_ = std::thread([this] { writer_loop(); });
}

DirectAppender::~DirectAppender() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  if (writer_.joinable()) writer_.join();
  if (direct_fd_ >= 0) ::close(direct_fd_);
  if (plain_fd_ >= 0) ::close(plain_fd_);
  for (char* b : blocks_) std::free(b);
}

void DirectAppender::append(const char* data, size_t n) {
  while (n > 0) {
    const size_t take = std::min(n, kBufferBytes - current_.used);
    std::memcpy(current_.data + current_.used, data, take);
    current_.used += take;
    data += take;
    n -= take;
    if (current_.used == kBufferBytes) submit();
  }
}

void DirectAppender::submit() {
  std::unique_lock<std::mutex> lock(mutex_);
  if (error_) {
    lock.unlock();
    throw_if_failed();
  }
  const long long next_offset = current_.offset + static_cast<long long>(current_.used);
  full_.push_back(current_);
  changed_.notify_all();
  changed_.wait(lock, [this] { return !free_.empty() || error_; });
  if (error_) {
    lock.unlock();
    throw_if_failed();
  }
  current_ = Buffer{free_.back(), 0, next_offset};
  free_.pop_back();
}

void DirectAppender::writer_loop() {
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    changed_.wait(lock, [this] { return !full_.empty() || stopping_; });
    if (full_.empty()) return;  // stopping, nothing left
    const Buffer b = full_.front();
    full_.pop_front();
    writing_ = true;
    const bool skip = error_ != 0;
    lock.unlock();
    if (!skip) {
      write_buffer(b, b.used);
      // The disk's cache flushed while the next rows are formatted, so that commit()'s fsync
      // finds little left to flush (on this project's VM a flush of 700 MB takes 0.4–0.5 s).
      unsynced_ += b.used;
      if (unsynced_ >= kSyncEveryBytes) {
        ::fdatasync(plain_fd_);  // (its failure shows again in commit()'s fsync)
        unsynced_ = 0;
      }
    }
    lock.lock();
    writing_ = false;
    free_.push_back(b.data);
    changed_.notify_all();
  }
}

void DirectAppender::write_buffer(const Buffer& b, size_t bytes) {
  // Whole aligned blocks directly (where allowed), the rest through the page cache.
  size_t done = 0;
  const size_t aligned = bytes - bytes % kAlign;
  while (done < aligned && direct_fd_ >= 0) {
    const ssize_t w = ::pwrite(direct_fd_, b.data + done, aligned - done, b.offset + static_cast<long long>(done));
    if (w > 0 && static_cast<size_t>(w) % kAlign == 0) {
      done += static_cast<size_t>(w);
      continue;
    }
    if (w < 0 && errno == EINVAL) {  // this file system does not take O_DIRECT: go on without it
      ::close(direct_fd_);
      direct_fd_ = -1;
      break;
    }
    if (w < 0 && errno == EINTR) continue;
    if (w > 0) {  // a short, unaligned direct write (a full disk): the rest as ordinary writes
      done += static_cast<size_t>(w);
      break;
    }
    const std::lock_guard<std::mutex> lock(mutex_);
    if (!error_) error_ = w < 0 ? errno : ENOSPC;
    return;
  }
  while (done < bytes) {
    const ssize_t w = ::pwrite(plain_fd_, b.data + done, bytes - done, b.offset + static_cast<long long>(done));
    if (w > 0) {
      done += static_cast<size_t>(w);
      continue;
    }
    if (w < 0 && errno == EINTR) continue;
    const std::lock_guard<std::mutex> lock(mutex_);
    if (!error_) error_ = w < 0 ? errno : ENOSPC;
    return;
  }
}

void DirectAppender::throw_if_failed() {
  int e = 0;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    e = error_;
  }
  if (e == 0) return;
  const std::string reason = e == ENOSPC  ? "no space left on the device"
                             : e == EFBIG ? "file too large (a file size limit)"
                                          : std::strerror(e);
  throw_io("cannot write '" + out_.target() + "': " + reason);
}

void DirectAppender::finish() {
  if (finished_) return;
  finished_ = true;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait(lock, [this] { return (full_.empty() && !writing_) || error_; });
  }
  throw_if_failed();
  write_buffer(current_, current_.used);  // the writer thread is idle: this thread writes the last one
  throw_if_failed();
  // The stream continues after the appended bytes.
  std::ofstream& stream = out_.stream();
  stream.seekp(0, std::ios::end);
  out_.check_stream();
}

}  // namespace photometria
