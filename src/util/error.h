// Errors that carry what went wrong and where: the file, the line, the value at fault.
//
// Every failure the user can cause is reported as a photometria::Error with a category that
// maps to the documented process exit code (README "Exit codes"):
//   BadInput      -> 1  (malformed file, out-of-range value, nothing to solve)
//   Io            -> 2  (missing/unreadable input, output path not writable)
//   NotConverged  -> 3  (solver hit its iteration cap above the tolerance)
// The message is one line, meant to be printed as "photometria: <message>".
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>

namespace photometria {

enum class ErrorKind { BadInput = 1, Io = 2, NotConverged = 3 };

class Error : public std::runtime_error {
 public:
  Error(ErrorKind kind, const std::string& message) : std::runtime_error(message), kind_(kind) {}
  ErrorKind kind() const { return kind_; }
  int exit_code() const { return static_cast<int>(kind_); }

 private:
  ErrorKind kind_;
};

// "file:line: message" when a line is known (line > 0), "file: message" otherwise.
inline std::string at(const std::string& file, long line = 0) {
  std::ostringstream s;
  s << file;
  if (line > 0) s << ':' << line;
  return s.str();
}

[[noreturn]] inline void throw_bad_input(const std::string& msg) { throw Error(ErrorKind::BadInput, msg); }
[[noreturn]] inline void throw_io(const std::string& msg) { throw Error(ErrorKind::Io, msg); }

}  // namespace photometria
