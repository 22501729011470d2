// photometria — command line. Parses, calls the library, prints. No physics here.
// Each command lives in its own apps/cmd_<name>.cpp and registers itself in main().
#include <signal.h>

#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>
#include <string>

#include "commands.h"
#include "distributed/ranks.h"
#include "io/atomic_file.h"
#include "util/error.h"

namespace pm = photometria;

namespace {

int run_command(int argc, char** argv) {
  CLI::App app{"Photometria: radiosity and form factors with Lambert's closed form"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "photometria 0.1.0");
  const std::vector<Command> commands = {add_solve_command(app), add_validate_command(app), add_formfactor_command(app),
                                         add_viewfactors_command(app), add_bench_command(app)};
  // Rank 0 speaks for an MPI run; the other ranks print nothing (their errors reach rank 0
  // through ranks::agree, or end the job).
  const bool speaks = pm::ranks::is_root();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return speaks ? app.exit(e) : 0;
    if (speaks) std::cerr << "photometria: " << e.what() << "\n";
    return 1;
  }
  try {
    for (const Command& c : commands)
      if (c.subcommand->parsed()) {
        const std::string name = c.subcommand->get_name();
        if (pm::ranks::distributed() && name != "viewfactors" && name != "solve")
          pm::ranks::agree(std::make_exception_ptr(pm::Error(
              pm::ErrorKind::BadInput, "'" + name +
                                           "' runs as one process; of the commands, 'solve' and "
                                           "'viewfactors' are split over MPI ranks (start it without mpirun)")));
        const int code = c.run();
        pm::finish_standard_output();  // a summary lost on a full disk is an error too
        return code;
      }
  } catch (const pm::ranks::SharedError& e) {
    // Every rank has it (ranks.h): one message, every rank's files cleaned up, the same exit code.
    if (speaks) std::cerr << "photometria: " << e.what() << "\n";
    return e.exit_code();
  } catch (const pm::Error& e) {
    std::cerr << "photometria: " << (speaks ? "" : "rank " + std::to_string(pm::ranks::rank()) + ": ") << e.what()
              << "\n";
    // This rank alone may have failed, while others wait for it in a collective: end them all.
    if (pm::ranks::distributed()) pm::ranks::abort_all(e.exit_code());
    return e.exit_code();
  } catch (const std::exception& e) {
    std::cerr << "photometria: " << (speaks ? "" : "rank " + std::to_string(pm::ranks::rank()) + ": ")
              << "internal error: " << e.what() << "\n";
    if (pm::ranks::distributed()) pm::ranks::abort_all(4);
    return 4;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // Past a file-size limit (ulimit -f) a write should fail with EFBIG, which the writers report
  // as a one-line error, rather than kill the process with SIGXFSZ and leave its temporary file.
  signal(SIGXFSZ, SIG_IGN);
  try {
    pm::ranks::start(&argc, &argv);  // only under mpirun (distributed/ranks.h)
  } catch (const pm::Error& e) {
    std::cerr << "photometria: " << e.what() << "\n";
    return e.exit_code();
  }
  const int code = run_command(argc, argv);
  pm::ranks::stop();
  return code;
}
