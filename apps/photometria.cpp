// photometria — command line. Parses, calls the library, prints. No physics here.
// Each command lives in its own apps/cmd_<name>.cpp and registers itself in main().
#include <signal.h>

#include <CLI/CLI.hpp>
#include <iostream>

#include "commands.h"
#include "io/atomic_file.h"
#include "util/error.h"

namespace pm = photometria;

int main(int argc, char** argv) {
  // Past a file-size limit (ulimit -f) a write should fail with EFBIG, which the writers report
  // as a one-line error, rather than kill the process with SIGXFSZ and leave its temporary file.
  signal(SIGXFSZ, SIG_IGN);
  CLI::App app{"Photometria: radiosity and form factors with Lambert's closed form"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "photometria 0.1.0");
  const std::vector<Command> commands = {add_solve_command(app), add_validate_command(app), add_formfactor_command(app),
                                         add_viewfactors_command(app), add_bench_command(app)};

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::cerr << "photometria: " << e.what() << "\n";
    return 1;
  }
  try {
    for (const Command& c : commands)
      if (c.subcommand->parsed()) {
        const int code = c.run();
        pm::finish_standard_output();  // a summary lost on a full disk is an error too
        return code;
      }
  } catch (const pm::Error& e) {
    std::cerr << "photometria: " << e.what() << "\n";
    return e.exit_code();
  } catch (const std::exception& e) {
    std::cerr << "photometria: internal error: " << e.what() << "\n";
    return 4;
  }
  return 0;
}
