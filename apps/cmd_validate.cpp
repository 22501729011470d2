// `photometria validate [--report DIR] [--quick]`: the analytic reference suite.
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>

#include "commands.h"
#include "util/error.h"
#include "validation/suite.h"

namespace pm = photometria;
namespace pv = photometria::validation;

namespace {

struct ValidateArgs {
  std::string report;
  std::string refs = PHOTOMETRIA_REFS_PATH;
  bool quick = false;
};

int run_validate(const ValidateArgs& a) {
  std::ifstream in(a.refs);
  if (!in) pm::throw_io("cannot open reference file '" + a.refs + "' (use --refs)");
  nlohmann::json refs;
  try {
    refs = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    pm::throw_bad_input(a.refs + ": " + e.what());
  }
  if (!a.report.empty()) std::filesystem::create_directories(a.report);

  std::cout << std::left << std::setw(46) << "scene" << std::setw(20) << "setting" << std::right << std::setw(8)
            << "patches" << std::setw(7) << "cases" << std::setw(13) << "max rel err" << std::setw(13) << "rms rel err"
            << std::setw(11) << "seconds" << "\n";
  pv::ValidationOptions opt;
  opt.quick = a.quick;
  opt.on_row = [](const pv::ValidationRow& r) {
    std::cout << std::left << std::setw(46) << r.scene << std::setw(20) << r.setting << std::right << std::setw(8)
              << r.patches << std::setw(7) << r.cases << std::setw(13) << std::setprecision(3) << std::scientific
              << r.max_rel_error << std::setw(13) << r.rms_rel_error << std::setw(11) << std::defaultfloat
              << std::setprecision(4) << r.seconds << "\n"
              << std::flush;
  };
  const auto rows = pv::run_validation(refs, opt);
  if (!a.report.empty()) {
    const std::string csv = (std::filesystem::path(a.report) / "validation.csv").string();
    const std::string png = (std::filesystem::path(a.report) / "error_vs_time.png").string();
    pv::write_validation_csv(csv, rows);
    const std::string md = (std::filesystem::path(a.report) / "validation_table.md").string();
    pv::write_validation_markdown(md, rows);
    pv::write_error_vs_time_plot(csv, png, rows);
    std::cerr << "wrote " << csv << ", " << md << " and " << png << "\n";
  }
  return 0;
}

}  // namespace

Command add_validate_command(CLI::App& app) {
  auto args = std::make_shared<ValidateArgs>();
  CLI::App* cmd = app.add_subcommand("validate", "Run the analytic reference suite: error against run time");
  cmd->add_option("--report", args->report, "Folder for validation.csv and error_vs_time.png");
  cmd->add_flag("--quick", args->quick, "A subset that runs in seconds");
  cmd->add_option("--refs", args->refs, "Reference file (default: the shipped tests/data/refs_public.json)");
  return {cmd, [args] { return run_validate(*args); }};
}
