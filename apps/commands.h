// The commands of the photometria executable. Each add_*_command() declares its options on
// `app` and returns the subcommand with the function that runs it (returning the exit code).
#pragma once

#include <CLI/CLI.hpp>
#include <functional>

struct Command {
  CLI::App* subcommand;
  std::function<int()> run;
};

Command add_solve_command(CLI::App& app);
Command add_validate_command(CLI::App& app);
Command add_formfactor_command(CLI::App& app);
Command add_viewfactors_command(CLI::App& app);
Command add_bench_command(CLI::App& app);
