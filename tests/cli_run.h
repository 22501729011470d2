// Running the photometria binary from a test: its exit code, standard output and standard error.
#pragma once

#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace cli_test {

struct CliRun {
  int exit_code;
  std::string out, err;
};

// Runs the shell command `command`, stdout through a pipe, stderr through `err_file`, which is
// removed afterwards. exit_code is −1 when the process did not exit normally (killed by a signal).
inline CliRun run_command(const std::string& command, const std::string& err_file) {
  const std::string cmd = command + " 2>" + err_file;
  CliRun r{0, {}, {}};
  FILE* pipe = popen(cmd.c_str(), "r");
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, pipe)) > 0) r.out.append(buf, n);
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(err_file);
  std::stringstream s;
  s << in.rdbuf();
  r.err = s.str();
  in.close();
  std::filesystem::remove(err_file);
  return r;
}

// Runs `PHOTOMETRIA_BINARY args` (the macro is set for every test target) as run_command.
inline CliRun run_cli(const std::string& args, const std::string& err_file) {
  return run_command(std::string(PHOTOMETRIA_BINARY) + " " + args, err_file);
}

}  // namespace cli_test
