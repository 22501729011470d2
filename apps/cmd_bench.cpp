// `photometria bench [--quick] [--csv FILE] [--threads T] [--json]`: the speed benchmark
// (validation/bench.h). Parses, runs, prints: a table on stdout (or one JSON object per row
// with --json), progress and skipped cases on stderr.
#include <unistd.h>

#include <cmath>
#include <iomanip>
#include <iostream>
#include <optional>
#include <sstream>

#include "commands.h"
#include "io/atomic_file.h"
#include "options.h"
#include "pipeline/memory.h"
#include "util/error.h"
#include "util/progress.h"
#include "validation/bench.h"

namespace pm = photometria;
namespace pv = photometria::validation;

namespace {

struct BenchArgs {
  bool quick = false, json = false, quiet = false;
  std::string csv;
  int threads = 0;
  int max_patches = 0;
  std::string only;
  std::optional<std::string> max_memory;
};

// "1.23e+07" style counts are hard to read in a table: M / k with three digits.
std::string rate(double x) {
  if (!std::isfinite(x)) return "-";
  if (x == 0) return "0";
  std::ostringstream s;
  s << std::setprecision(3);
  if (x >= 1e6) s << x / 1e6 << " M";
  else if (x >= 1e3) s << x / 1e3 << " k";
  else s << x;
  return s.str();
}

std::string secs(double x) {
  if (!std::isfinite(x)) return "-";
  std::ostringstream s;
  s << std::fixed << std::setprecision(x < 10 ? 3 : 1) << x;
  return s.str();
}

std::string sci(double x) {
  if (!std::isfinite(x)) return "-";
  std::ostringstream s;
  s << std::scientific << std::setprecision(1) << x;
  return s.str();
}

void print_header() {
  std::cout << std::left << std::setw(11) << "scene" << std::setw(13) << "setting" << std::setw(12) << "task"
            << std::setw(7) << "vis" << std::right << std::setw(8) << "N" << std::setw(12) << "pairs" << std::setw(11)
            << "pairs/s" << std::setw(11) << "evals/s" << std::setw(10) << "rays" << std::setw(10) << "rays/s"
            << std::setw(9) << "ff s" << std::setw(8) << "solve s" << std::setw(9) << "gather s" << std::setw(9)
            << "total s" << std::setw(11) << "peak mem"
            << "  " << std::left << std::setw(14) << "matrix" << std::right << std::setw(9) << "|rs-1|" << std::setw(9)
            << "rel err" << std::setw(4) << "T"
            << "\n";
}

void print_row(const pv::BenchRow& r) {
  std::cout << std::left << std::setw(11) << r.scene << std::setw(13) << r.setting << std::setw(12) << r.task;
  if (!r.skipped.empty()) {
    std::cout << std::right << std::setw(7 + 8) << pm::format_count(r.patches) << "  skipped: " << r.skipped << "\n"
              << std::flush;
    return;
  }
  std::cout << std::setw(7) << r.visibility << std::right << std::setw(8) << pm::format_count(r.patches)
            << std::setw(12) << pm::format_count(r.pairs_evaluated) << std::setw(11) << rate(r.pairs_per_second)
            << std::setw(11) << rate(r.evaluations_per_second) << std::setw(10) << rate(double(r.rays_cast))
            << std::setw(10) << (r.rays_cast > 0 ? rate(r.rays_per_second) : "-") << std::setw(9)
            << secs(r.form_factor_seconds) << std::setw(8) << secs(r.solve_seconds) << std::setw(9)
            << secs(r.gather_seconds) << std::setw(9) << secs(r.total_seconds) << std::setw(11)
            << (r.peak_memory_per_case ? "" : "<") + pm::format_bytes(r.peak_memory_bytes) << "  " << std::left
            << std::setw(14) << r.matrix_storage << std::right << std::setw(9) << sci(r.max_row_sum_error)
            << std::setw(9) << sci(r.max_rel_error) << std::setw(4) << r.threads << "\n"
            << std::flush;
}

int run_bench(const BenchArgs& a) {
  pv::BenchOptions opt;
  opt.quick = a.quick;
  opt.threads = a.threads;
  opt.max_patches = a.max_patches;
  opt.only = a.only;
  if (a.max_memory && !pm::parse_memory_size(*a.max_memory, opt.max_memory_bytes))
    pm::throw_bad_input("--max-memory: '" + *a.max_memory + "' is not a size (e.g. 2G, 512M)");
  // The CSV target is opened before minutes of work (an unwritable folder fails at once).
  std::optional<pm::AtomicOutput> csv;
  if (!a.csv.empty()) csv.emplace(a.csv);
  if (!a.json) print_header();
  // Each case's progress and time left on stderr: a bar on a terminal, a line every 5 s elsewhere.
  pm::ProgressReporter progress(std::cerr, isatty(STDERR_FILENO));
  if (!a.quiet) opt.progress = progress.callback();
  opt.on_start = [&progress](const std::string& label) {
    progress.clear();
    std::cerr << "bench: " << label << "...\n" << std::flush;
  };
  opt.on_row = [&a, &progress](const pv::BenchRow& r) {
    progress.clear();
    if (!r.skipped.empty())
      std::cerr << "bench: skipped " << r.scene << " " << r.setting << " " << r.task << ": " << r.skipped << "\n";
    if (a.json) std::cout << pv::bench_json(r).dump() << "\n" << std::flush;
    else print_row(r);
  };
  const std::vector<pv::BenchRow> rows = pv::run_bench(opt);
  if (csv) {
    pv::write_bench_csv(*csv, rows);
    csv->commit();
    std::cerr << "bench: wrote " << a.csv << "\n";
  }
  return 0;
}

}  // namespace

Command add_bench_command(CLI::App& app) {
  auto args = std::make_shared<BenchArgs>();
  CLI::App* cmd = app.add_subcommand(
      "bench", "Speed benchmark: generated cube and furnished rooms through the real pipeline (docs/performance.md)");
  cmd->add_flag("--quick", args->quick, "Smallest size of each scene only (a crash check, well under a minute)");
  cmd->add_option("--csv", args->csv, "Also write the rows to this CSV file (atomically)");
  cmd->add_option("--threads", args->threads, "Threads (default: all cores)")
      ->check(options::integer_in(0, options::kMaxThreads));
  cmd->add_flag("--json", args->json, "One JSON object per row on stdout instead of the table");
  cmd->add_flag("--quiet", args->quiet, "No progress within a case on stderr");
  cmd->add_option("--max-memory", args->max_memory,
                  "Skip cases whose memory estimate exceeds this (e.g. 2G; default: MemAvailable)");
  cmd->add_option("--max-patches", args->max_patches, "Skip cases with more patches than this (0: no limit)")

      ->check(options::integer_in(0, std::numeric_limits<int>::max()));
  cmd->add_option("--only", args->only,
                  "Run only the cases whose label contains this text (labels: \"cube n=32 solve\", "
                  "\"cube n=32 viewfactors\", \"room edge=0.112 m solve\", ...)");
  return {cmd, [args] { return run_bench(*args); }};
}
