// Atomic output: write to a temporary file beside the target, rename over it on success.
//
// A failed or interrupted run never leaves a half-written result: until commit() the target is
// untouched, and the destructor removes the temporary file if commit() was not reached.
#pragma once

#include <string>

namespace photometria {

class AtomicOutput {
 public:
  // Checks that the target's folder exists and is writable; throws Error(Io) naming the path.
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
};

}  // namespace photometria
