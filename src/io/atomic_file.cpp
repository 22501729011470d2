#include "io/atomic_file.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "util/error.h"

namespace photometria {

AtomicOutput::AtomicOutput(std::string target) : target_(std::move(target)) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::path(target_).has_parent_path() ? fs::path(target_).parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw_io("cannot write '" + target_ + "': folder '" + dir.string() + "' does not exist");
  if (fs::is_directory(target_, ec)) throw_io("cannot write '" + target_ + "': it is a folder");
  temp_ = target_ + ".tmp-" + std::to_string(::getpid());
  // Probe now, before any long computation, that the folder takes a new file.
  std::ofstream probe(temp_);
  if (!probe) throw_io("cannot write '" + target_ + "': " + std::strerror(errno));
  probe.close();
}

AtomicOutput::~AtomicOutput() {
  if (!committed_) std::remove(temp_.c_str());
}

void AtomicOutput::commit() {
  if (std::rename(temp_.c_str(), target_.c_str()) != 0)
    throw_io("cannot rename '" + temp_ + "' to '" + target_ + "': " + std::strerror(errno));
  committed_ = true;
}

}  // namespace photometria
