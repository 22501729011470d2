// `photometria validate [--report DIR] [--quick]`: the analytic reference suite.
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <optional>

#include "commands.h"
#include "io/atomic_file.h"
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
  } catch (const nlohmann::json::exception& e) { pm::throw_bad_input(a.refs + ": " + e.what()); }
  // The report's three files are opened now (an unwritable folder fails before the run) and
  // committed together at the end, so a failed report leaves the earlier one as it was.
  struct Report {
    explicit Report(const std::filesystem::path& dir)
        : csv((dir / "validation.csv").string()),
          md((dir / "validation_table.md").string()),
          png((dir / "error_vs_time.png").string()) {}
    pm::AtomicOutput csv, md, png;
  };
  std::optional<Report> report;
  if (!a.report.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(a.report, ec);
    if (ec) pm::throw_io("cannot create the report folder '" + a.report + "': " + ec.message());
    report.emplace(std::filesystem::path(a.report));
  }

  std::cout << std::left << std::setw(46) << "scene" << std::setw(20) << "setting" << std::right << std::setw(8)
            << "patches" << std::setw(7) << "cases" << std::setw(13) << "max rel err" << std::setw(13) << "rms rel err"
            << std::setw(11) << "seconds"
            << "\n";
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
  if (report) {
    pv::write_validation_csv(report->csv, rows);
    pv::write_validation_markdown(report->md, rows);
    pv::write_error_vs_time_plot(report->png, report->csv.target(), rows);
    report->csv.finish();
    report->md.finish();
    report->png.finish();
    report->csv.commit();
    report->md.commit();
    report->png.commit();
    std::cerr << "wrote " << report->csv.target() << ", " << report->md.target() << " and " << report->png.target()
              << "\n";
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
