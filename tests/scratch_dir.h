// Scratch folders for tests that write files.
//
// Every folder is new (mkdtemp), never one named after the process id: ids are reused, and a
// folder a finished test process left behind under the same name (an earlier CTest run on the same
// machine, or the sanitizer run after the Release run) would hold stale outputs, so a test that
// checks "no output file is written" could fail, or pass, on another run's file.
#pragma once

#include <stdlib.h>

#include <filesystem>
#include <map>
#include <stdexcept>
#include <string>
#include <system_error>

namespace test_scratch {

// A new, empty folder under the system's temporary folder, named `prefix` + six random characters.
inline std::filesystem::path fresh_dir(const std::string& prefix) {
  std::string pattern = (std::filesystem::temp_directory_path() / (prefix + "XXXXXX")).string();
  if (::mkdtemp(pattern.data()) == nullptr)
    throw std::system_error(errno, std::generic_category(), "mkdtemp " + pattern);
  return pattern;
}

// One fresh folder per `prefix` for the whole test process, made on first use.
inline const std::filesystem::path& process_dir(const std::string& prefix) {
  static std::map<std::string, std::filesystem::path> dirs;
  auto it = dirs.find(prefix);
  if (it == dirs.end()) it = dirs.emplace(prefix, fresh_dir(prefix)).first;
  return it->second;
}

}  // namespace test_scratch
