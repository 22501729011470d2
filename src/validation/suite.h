// The analytic reference suite: error against run time at a ladder of accuracy settings.
//
// Every reference comes from a closed form (tests/data/refs_public.json; Howell's catalog cases,
// enclosure identities) or from an identity that is exact for the continuous problem (white furnace
// B = E/(1−ρ); a sphere enclosure with an emitting cap B_i = E_i + ρ/(1−ρ)·Ē). Each scene family is
// run at several settings (patch subdivision n, receiver quadrature q, tessellation) and yields one
// row per setting.
#pragma once

#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "io/atomic_file.h"

namespace photometria::validation {

struct ValidationRow {
  std::string scene;    // family name: one line in the error-against-time plot
  std::string setting;  // human description of the accuracy setting
  int patches = 0;      // patches in the discretised scene (0 for point queries)
  int quadrature = 1;   // receiver rule order
  int cases = 0;        // reference values compared
  double max_rel_error = 0.0;
  double rms_rel_error = 0.0;
  double seconds = 0.0;  // wall time of the computation being validated
};

struct ValidationOptions {
  bool quick = false;                                // a subset that runs in seconds (CI)
  std::function<void(const ValidationRow&)> on_row;  // called as each row completes
};

// Runs the suite against `refs` (the parsed reference file). Throws Error(BadInput) if a
// reference case it needs is missing.
std::vector<ValidationRow> run_validation(const nlohmann::json& refs, const ValidationOptions& options);

// The writers fill an AtomicOutput (io/atomic_file.h) without committing it, so that a command
// can open every output of a report before the long run and commit them only when all were
// written (a failed report leaves none of its files changed). The overloads taking a path open,
// write and commit one file. All throw Error(Io) naming the file when its bytes do not reach
// the disk.

// Rows as CSV (header: scene,setting,patches,quadrature,cases,max_rel_error,rms_rel_error,seconds).
void write_validation_csv(AtomicOutput& out, const std::vector<ValidationRow>& rows);
void write_validation_csv(const std::string& path, const std::vector<ValidationRow>& rows);

// Rows as a Markdown table (for docs/validation.md).
void write_validation_markdown(AtomicOutput& out, const std::vector<ValidationRow>& rows);

// Log-log plot of max relative error against seconds, one line per scene, through gnuplot
// (pngcairo); `title` names the data in the plot's title. Throws Error(Io) if gnuplot is
// missing, fails, or leaves an incomplete picture.
void write_error_vs_time_plot(AtomicOutput& png, const std::string& title, const std::vector<ValidationRow>& rows);
void write_error_vs_time_plot(const std::string& csv_path, const std::string& png_path,
                              const std::vector<ValidationRow>& rows);

}  // namespace photometria::validation
