// The `photometria viewfactors` job: scene -> patch view factors -> aggregated, enforced and
// checked matrix -> output files, with the figures of its summary (viewfactors/report.h).
//
// run_view_factor_job() does, in this order:
//   1. refuses a points_output that is the output itself, then opens every output
//      (io/atomic_file.h: creates its temporary file), so that an unwritable path fails in a
//      second, before the long work;
//   2. loads the scene (warnings go to ViewFactorJob::on_load_warning) and the points file, so
//      that a bad points file fails before the fill;
//   3. compute_view_factors(), make_aggregation(), aggregate(), enforce() when asked,
//      check_matrix() (viewfactors/viewfactors.h); for a .vs3 input whose C line has emit=1,
//      then exchange_factors() with the surfaces' emissivities (Hottel's script-F, after the
//      enforcement as View3D normalises its enclosure before IntFac) and check_matrix() again;
//   4. writes the matrix (io/viewfactor_output.h) and, with points, the point factors; a sparse
//      output whose rows are streamed (ViewFactorOptions::stream) is written during step 3
//      instead, and steps 3's aggregation and checks are made row by row;
//   5. commits the outputs all or nothing: the matrix first, then the point factors; when the
//      point factors fail to commit, the committed matrix is removed again.
// It prints nothing.
//
// On the R ranks of an MPI run (distributed/ranks.h, R > 1), every rank loads the scene and
// patches it, fills its share of the rows (a spatial partition balanced by estimated cost,
// distributed/row_partition.h) and keeps them formatted; then every rank writes its rows into the
// one file at their offsets (distributed/shared_file.h), so no rank ever holds the whole matrix.
// Rank 0 alone opens, commits and names the outputs and computes the point factors. The rows are
// always streamed, so what cannot be streamed (--by group, --enforce, C emit=1, subsurfaces) is
// refused. The results are the bytes of one process's `--stream yes` run. Failures are agreed
// over the ranks (ranks::agree): every rank throws ranks::SharedError, rank 0's files are removed.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "formfactors/formfactors.h"
#include "io/viewfactor_output.h"
#include "viewfactors/viewfactors.h"

namespace photometria {

// What to compute and where to write it: the resolved options of `photometria viewfactors`.
struct ViewFactorJob {
  std::string scene;                                // input: mesh, View3D .vs3 or scene .json file
  bool flip_normals = false;                        // reverse every face on load (inside-out exports)
  std::string output;                               // the matrix file (-o); required
  AggregateLevel level = AggregateLevel::Group;     // rows/columns: groups, input faces or patches
  ViewFactorFormat format = ViewFactorFormat::Csv;  // the file's layout (io/viewfactor_output.h);
                                                    // View3d from a .vs3 input copies its emissivities
  double threshold = 0.0;                           // Sparse only: factors below it (in [0, 1]) are not written
  Enforcement enforcement = Enforcement::None;      // applied to the aggregated matrix before writing;
                                                    // Closure and Both also set View3D's `encl` flag
  std::string points;                               // points file (.json or .csv, load_points); empty: none
  std::string points_output;                        // where the point factors go; empty: output + ".points.csv"
  // Sparse only: write the rows while they are filled, never holding the matrix
  // (ViewFactorOptions::stream: auto streams when the matrix would not fit the memory limit).
  RowStreaming stream = RowStreaming::Auto;
  // The fill: patching (default: one patch per input face), accuracy (default 1e-7), visibility,
  // rays, threads, storage, memory limit. Its `level`, `enforcement` and `points` are set by the
  // job from the fields above (they size the memory estimate), whatever they hold here.
  ViewFactorOptions fill;
  // Called once per load warning (scene/scene.h load_warnings), with the loaded scene's source
  // path, right after the load (so before any later error). Optional.
  std::function<void(const std::string& scene_source, const std::string& warning)> on_load_warning;
};

// What was done: everything the summary reports.
struct ViewFactorJobResult {
  // The job as run: points_output resolved (empty without points), fill.level, fill.enforcement
  // and fill.points (the number of points read) as used, on_load_warning cleared.
  ViewFactorJob job;

  // Sizes.
  int faces = 0;                   // faces of the loaded (cleaned) scene
  int patches = 0;                 // N, patches of the fill
  std::vector<std::string> names;  // the G output surfaces (Aggregation::names)
  std::vector<double> areas;       // their areas, m²
  int surfaces() const { return static_cast<int>(names.size()); }

  // The written matrix (G × G, row I = from surface I, after enforcement; Hottel's exchange
  // factors when exchange_factors) and its checks.
  ViewFactorMatrix F;
  MatrixChecks checks;
  // A .vs3 input with `C emit=1`: F holds the exchange factors (script-F) of the geometric
  // factors (whose checks are geometric_checks) and `emissivities`.
  bool exchange_factors = false;
  MatrixChecks geometric_checks;         // the geometric factors' checks; all zero unless exchange_factors
  std::vector<double> emissivities;      // per output surface, from the .vs3 (with exchange factors or
                                         // --format view3d); empty otherwise
  EnforcementReport enforcement_report;  // all zero when enforcement is None
  SparseWriteStats sparse;               // drop statistics; all zero unless format is Sparse
  // The rows went to the file as they were filled (F is then empty, and checks.reciprocity_checked
  // false unless the fill mirrored its rows in bands: FillStats::streamed_reciprocity_error), and
  // why or why not (PatchViewFactors::stream_reason).
  bool streamed = false;
  std::string stream_reason;
  // A .vs3 input's C line: per key given, what became of it ("eps=1e-05: superseded by
  // --accuracy 1e-07", ...), in the order of view3d_control_notes(); empty otherwise.
  std::vector<std::string> view3d_control;

  // The fill.
  std::string visibility_mode;    // "none", "exact" or "rays"
  std::string visibility_reason;  // why that mode was chosen
  std::string matrix_storage;     // patch matrix storage used: "dense double", "sparse float", ...
  double matrix_bytes = 0.0;      // bytes held by the patch matrix
  ViewFactorMemory memory;        // the estimate checked before the fill, and the limit
  FillStats fill;                 // pair counts, rays, kernel evaluations

  // The processes (`mpirun -np R photometria viewfactors ...`): R ranks (1 without MPI), the fill's
  // threads on each, and per rank its rows, their estimated cost (distributed/row_partition.h)
  // and the seconds its rows took to fill (empty on one rank).
  int ranks = 1;
  int threads_per_rank = 1;
  std::vector<int> rows_per_rank;
  std::vector<double> estimated_cost_per_rank;
  std::vector<double> fill_seconds_per_rank;
  std::vector<double> peak_memory_per_rank;  // bytes, each rank's peak resident memory at its end
  // max / mean of fill_seconds_per_rank (1: perfectly balanced); 1 on one rank.
  double load_imbalance() const;

  double seconds = 0.0;  // wall time of the whole job, s
};

// Throws photometria::Error: Io when an output cannot be written or an input cannot be opened;
// BadInput when points_output is the output file, the scene or the points file is malformed,
// the scene has no patch or the memory estimate exceeds the limit (compute_view_factors), or
// with `C emit=1` when every emissivity is 0 or the exchange-factor system is singular (one line
// naming the scene file).
// Whatever is thrown, no output file is left (and no temporary file).
// What this job does with each key of a View3D C line (Scene::settings["view3d"], keys in lower
// case as the loader keeps them): honoured, superseded by an option, or ignored, and why.
std::vector<std::string> view3d_control_notes(const nlohmann::json& control, const ViewFactorJob& job);

ViewFactorJobResult run_view_factor_job(const ViewFactorJob& job);

}  // namespace photometria
