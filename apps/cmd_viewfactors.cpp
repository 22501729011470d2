// `photometria viewfactors SCENE -o VF.csv [--by group|face|patch] [--format ...] [--enforce ...]
// [--points FILE] [--max-memory SIZE] [--matrix ...]`: view-factor matrices for radiative heat transfer
// (docs/viewfactors.md).
#include <unistd.h>

#include <iostream>
#include <memory>
#include <string>

#include "commands.h"
#include "distributed/ranks.h"
#include "formfactors/storage.h"
#include "options.h"
#include "pipeline/memory.h"
#include "util/error.h"
#include "util/progress.h"
#include "viewfactors/job.h"
#include "viewfactors/report.h"
#include "viewfactors/viewfactors.h"

namespace pm = photometria;

namespace {

struct ViewFactorArgs {
  std::string scene, output, by = "group", format = "csv", enforce = "none", visibility = "auto", points, points_output,
                             max_memory, matrix = "auto", matrix_precision = "auto", stream = "auto";
  double threshold = 0.0, max_edge = 0.0, accuracy = 1e-7, occluded_accuracy = photometria::kDefaultOccludedAccuracy;
  std::string rays = "auto";
  int threads = 0;
  bool json = false, flip_normals = false, quiet = false;
};

// The options as the job takes them; throws BadInput (one line naming the option) on a value
// it does not know.
pm::ViewFactorJob job_of(const ViewFactorArgs& a) {
  pm::ViewFactorJob job;
  if (!pm::aggregate_level_from_name(a.by, job.level))
    pm::throw_bad_input("--by: unknown level '" + a.by + "' (group, face or patch)");
  if (!pm::view_factor_format_from_name(a.format, job.format))
    pm::throw_bad_input("--format: unknown format '" + a.format + "' (csv, sparse, binary or view3d)");
  if (!pm::enforcement_from_name(a.enforce, job.enforcement))
    pm::throw_bad_input("--enforce: unknown mode '" + a.enforce + "' (none, reciprocity, closure or both)");
  pm::ViewFactorOptions& opt = job.fill;
  opt.visibility = pm::parse_visibility_mode(a.visibility);
  // The numeric options are range-checked when parsed (options.h).
  opt.accuracy = a.accuracy;
  opt.occluded_accuracy = a.occluded_accuracy;
  opt.patching.max_edge = a.max_edge;
  opt.rays = pm::parse_ray_count(a.rays);
  opt.threads = a.threads;
  if (!a.max_memory.empty() && !pm::parse_memory_size(a.max_memory, opt.max_memory_bytes))
    pm::throw_bad_input("--max-memory: '" + a.max_memory + "' is not a size (e.g. 512M, 2G, 1.5GiB)");
  opt.matrix_layout = pm::parse_layout(a.matrix);
  opt.matrix_precision = pm::parse_precision(a.matrix_precision);
  job.scene = a.scene;
  job.flip_normals = a.flip_normals;
  job.output = a.output;
  job.threshold = a.threshold;
  if (!pm::row_streaming_from_name(a.stream, job.stream))
    pm::throw_bad_input("--stream: unknown mode '" + a.stream + "' (auto, yes or no)");
  job.points = a.points;
  job.points_output = a.points_output;
  job.on_load_warning = [](const std::string& source, const std::string& w) {
    std::cerr << "photometria: warning: " << source << ": " << w << "\n";
  };
  return job;
}

int run(const ViewFactorArgs& a) {
  pm::ViewFactorJob job = job_of(a);
  // The fill's progress and time left on stderr: a bar on a terminal, a line every 5 s elsewhere.
  pm::ProgressReporter progress(std::cerr, isatty(STDERR_FILENO));
  // On MPI ranks rank 0 shows its own rows' progress and prints the summary of all.
  const bool speaks = pm::ranks::is_root();
  if (!a.quiet && speaks) job.fill.progress = progress.callback();
  const pm::ViewFactorJobResult r = pm::run_view_factor_job(job);
  progress.clear();
  if (!speaks) return 0;
  if (a.json) std::cout << pm::viewfactor_summary_json(r).dump(2) << std::endl;
  else std::cout << pm::viewfactor_summary_text(r);
  return 0;
}

}  // namespace

Command add_viewfactors_command(CLI::App& app) {
  auto a = std::make_shared<ViewFactorArgs>();
  CLI::App* sub = app.add_subcommand("viewfactors",
                                     "View-factor matrix between groups, faces or patches (radiative heat transfer)");
  sub->add_option("scene", a->scene, "Mesh (.obj .off .ply .stl .om), View3D input (.vs3) or scene file (.json)")
      ->required();
  sub->add_option("-o,--output", a->output, "Output file")->required();
  sub->add_option("--by", a->by, "Aggregation level: group, face or patch (default group)");
  sub->add_option("--format", a->format, "csv (dense, default), sparse (i,j,F triplets), binary or view3d");
  sub->add_option("--threshold", a->threshold,
                  "Sparse output: drop factors below this (the summary reports the dropped row sums)")
      ->check(options::real_in(0, 1));
  sub->add_option("--stream", a->stream,
                  "By face or patch, one patch per face: write rows while they are filled, never holding the matrix "
                  "(no reciprocity check): auto (default: when the matrix would not fit the memory limit), yes or no");
  sub->add_option("--enforce", a->enforce, "none (default), reciprocity, closure or both (closed enclosures)");
  sub->add_option("--points", a->points,
                  "Points with normals (.json or .csv): factors from each point to each surface");
  sub->add_option("--points-output", a->points_output, "Where to write the point factors (default OUTPUT.points.csv)");
  sub->add_option("--max-edge", a->max_edge,
                  "Split faces into patches with edges at most this long, metres (default: no split)")
      ->check(options::real_in(0, options::kInf));
  sub->add_option("--accuracy", a->accuracy, "Per-pair relative tolerance for unblocked pairs (default 1e-7)")
      ->check(options::real_in(0, 1, true, true));
  sub->add_option("--occluded-accuracy", a->occluded_accuracy,
                  "Absolute tolerance on each row's sum over the pairs with occluders in their shaft, "
                  "integrated adaptively with exact visibility (default 1e-3; 0: the fixed --quadrature rule)")
      ->check(options::real_in(0, 1, false, true));
  sub->add_option("--visibility", a->visibility, "auto (default), none, rays or exact");
  sub->add_option("--rays", a->rays,
                  "Rays per (point, patch) in ray visibility: auto (default: 8² to 32², until the estimated error "
                  "meets --accuracy) or a count in 1..2²⁴")
      ->check(options::auto_or_integer_in(1, 1 << 24));
  sub->add_option(
      "--max-memory", a->max_memory,
      "Refuse before the fill when the memory estimate exceeds this: 512M, 2G, ... (default: MemAvailable)");
  sub->add_option("--matrix", a->matrix,
                  "Patch form-factor storage: auto | dense | sparse (default auto: the smaller for the scene)");
  sub->add_option("--matrix-precision", a->matrix_precision,
                  "Patch form-factor entries: auto | double | float (default auto: double unless only float fits the "
                  "memory limit; float halves the matrix)");
  sub->add_option(
         "--threads", a->threads,
         "Threads for the fill (default: all cores; under mpirun, the cores divided among the ranks on the machine)")
      ->check(options::integer_in(0, options::kMaxThreads));
  sub->add_flag("--flip-normals", a->flip_normals, "Reverse every face (inside-out exports)");
  sub->add_flag("--json", a->json, "Print a machine-readable summary on stdout");
  sub->add_flag("--quiet", a->quiet, "No progress on stderr");
  return {sub, [a]() { return run(*a); }};
}
