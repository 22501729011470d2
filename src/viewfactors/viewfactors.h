// View factors for radiative heat transfer: patch factors aggregated to groups / faces / patches,
// their checks, optional reciprocity/closure enforcement, and point-to-surface factors.
//
// compute_view_factors() runs load-independent stages of the solve pipeline (patching,
// visibility, form-factor fill; see pipeline/solve.h and formfactors/formfactors.h) with
// settings chosen for accuracy rather than speed: per-pair integration to a relative tolerance of
// 1e-7 for pairs nothing can block, and visibility `auto` (none in a convex enclosure, else the
// cheaper of exact clipping and rays by visibility/choice.h's estimate).
//
// Aggregation (area-weighted, the definition of a view factor between unions of surfaces):
//   F_IJ = (1 / A_I) Σ_{i∈I} A_i Σ_{j∈J} F_ij,   A_I = Σ_{i∈I} A_i
// (Modest, "Radiative Heat Transfer", 3rd ed., 2013, eq. 4.19 / Howell's catalog rule for
// composite surfaces). It keeps reciprocity (A_I F_IJ = A_J F_JI) and row sums exactly.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "formfactors/formfactors.h"
#include "patching/patching.h"
#include "pipeline/solve.h"
#include "scene/scene.h"

namespace photometria {

// Row-major dense matrix of view factors, row = emitting (from) surface.
using ViewFactorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

enum class AggregateLevel { Group, Face, Patch };
// "group", "face", "patch" (the names of `viewfactors --by`).
std::string aggregate_level_name(AggregateLevel level);
// The level named `name` (as aggregate_level_name) into `out`; false when unknown.
bool aggregate_level_from_name(const std::string& name, AggregateLevel& out);

inline constexpr double kDefaultOccludedAccuracy = 1e-3;

struct Aggregation;  // below: the output surfaces

// Whether the fill streams its rows to the output instead of storing the N × N matrix
// (`viewfactors --stream`, ViewFactorOptions::stream).
enum class RowStreaming { Auto, Yes, No };
// "auto", "yes", "no".
std::string row_streaming_name(RowStreaming mode);
// The mode named `name` (as row_streaming_name) into `out`; false when unknown.
bool row_streaming_from_name(const std::string& name, RowStreaming& out);

struct ViewFactorOptions {
  PatchingOptions patching;  // default: no subdivision beyond the input faces
  double accuracy = 1e-7;    // per-pair relative tolerance for pairs nothing can block
  int quadrature = 6;        // receiver rule order for pairs needing visibility
  // > 0, with exact visibility: the pairs of a row with occluders in their shaft are integrated
  // adaptively, together, to this absolute tolerance on their sum (what the row sum may be off;
  // formfactors/occluded_row.h); 0: the fixed rule above. The default's estimate is conservative:
  // on the 1,666-face room its rows were within 3.8e-5 (docs/performance.md), at 1.9 times the
  // fixed rule's time, whose rows were off by up to 1.3e-3.
  double occluded_accuracy = kDefaultOccludedAccuracy;
  VisibilityMode visibility = VisibilityMode::Auto;
  int rays = kAdaptiveRays;  // rays per (receiver point, patch) in ray mode; kAdaptiveRays: until
                             // the estimated error meets `accuracy` (visibility.h RaySampling)
  uint64_t seed = 1;
  int threads = 0;  // OpenMP threads for the fill; 0 = all cores
  // Optional: called with the stage ("form factors") and its fraction done, from one thread at
  // a time (util/progress.h shows it).
  std::function<void(const std::string& stage, double fraction)> progress;
  // Storage of the patch-level matrix (formfactors/storage.h), chosen as `solve` does
  // (pipeline/memory.h choose_storage): layout Auto picks dense or sparse from the estimated
  // share of facing pairs; precision Auto is double unless only float fits the memory limit.
  MatrixLayout matrix_layout = MatrixLayout::Auto;
  MatrixPrecision matrix_precision = MatrixPrecision::Auto;
  // Memory guard: refuse (BadInput) before the fill when the estimate (ViewFactorMemory) exceeds
  // this many bytes; 0 = MemAvailable (pipeline/memory.h), as `solve --max-memory`.
  double max_memory_bytes = 0.0;
  // What the caller does after the fill, so that the estimate covers it: the level it
  // aggregates to (the G × G result is dense), whether it enforces (--enforce: four more G × G
  // matrices at the peak) and how many point rows (P × G) it computes.
  AggregateLevel level = AggregateLevel::Patch;
  bool enforcement = false;
  bool exchange_factors = false;  // exchange_factors() (three more G × G matrices at its peak)
  int points = 0;
  // Streaming: each filled row is handed to a row sink (FillOptions::row_sink: any thread, any
  // order; false stops the fill) instead of being stored, so that memory follows the rows in
  // flight, not N². Possible when row_sink_for is given, the level is face or patch with one
  // patch per output surface (a patch row is an output row, of_patch a permutation), and neither
  // enforcement nor exchange factors need the whole matrix. Auto: stream when possible and either
  // the stored matrix with its output copy would exceed the memory limit, or nothing blocks and
  // the closed forms can be mirrored in bands within the limit (FillOptions::
  // streamed_mirror_bytes: less work and memory than storing); Yes: stream (BadInput when not
  // possible), mirrored in bands where that fits; No: never (the memory check refuses what does
  // not fit).
  RowStreaming stream = RowStreaming::Auto;
  // Called once streaming is decided, before the fill, with the patches and the output surfaces;
  // returns the sink of the patch rows (row i of the patch matrix, N entries in patch order).
  std::function<std::function<bool(int, const double*)>(const PatchMesh&, const Aggregation&)> row_sink_for;
  // One rank of an MPI run (viewfactors/job.h): called after patching and the memory check, before
  // the fill, with the patches; returns the rows (patch indices) this process fills. The rows are
  // then streamed (BadInput naming why when they cannot be). Empty function: every row.
  std::function<std::vector<int>(const PatchMesh&)> rows_for;
  // What the caller holds besides, for the memory estimate of a streamed fill: bytes per matrix
  // entry of the rows it keeps (an MPI rank keeps its formatted rows until every rank is done),
  // and the share of the rows it keeps (1 / ranks).
  double held_bytes_per_entry = 0.0;
  double held_row_share = 0.0;
  // Processes sharing this machine's memory (the ranks of an MPI run on it): without
  // max_memory_bytes, the limit of a streamed fill is MemAvailable divided among them.
  int ranks_per_machine = 1;
};

// The memory estimate, made after patching and before visibility and the fill.
//   estimated_bytes = matrix_bytes + per-patch arrays (MemoryEstimate::per_patch_bytes × N)
//                     + output_bytes
//   matrix_bytes    = the N × N patch matrix in `storage` (storage.h matrix_bytes())
//   output_bytes    = 8 G² (aggregated matrix) × (1 + 4 with enforcement + 3 with exchange
//                     factors) + 8 P G (points)
// An upper bound: where every surface is one patch and the patch matrix is dense double, the
// first output matrix is the patch matrix itself (aggregate(FormFactors&&, ...)), not a copy.
struct ViewFactorMemory {
  MemoryEstimate patches;      // pipeline/memory.h: facing pairs, per-patch bytes
  int surfaces = 0;            // G, rows of the output
  std::string storage;         // "dense double", "sparse float", ...
  std::string storage_reason;  // "requested (--matrix sparse)" or "auto: ..."
  // Streamed: matrix_bytes and output_bytes are 0, and estimated_bytes is the per-patch arrays,
  // the rows in flight (threads × kStreamedRowBytes × N) and the rows held
  // (held_bytes_per_entry × held_row_share × N², ViewFactorOptions), and, where a scene without
  // visibility mirrors its closed forms while streaming, the blocks it holds for that
  // (formfactors.h streamed_mirror_peak_bytes; used only where it fits the limit).
  double matrix_bytes = 0.0, output_bytes = 0.0, estimated_bytes = 0.0;
  double limit_bytes = 0.0;  // the limit checked against (0 = unknown: not checked)
  std::string limit_source;  // "--max-memory" or "MemAvailable"
};

// Bytes per patch of one row in flight when streaming: the row (8 N), its receiver kernels and
// facing classes (formfactors.cpp RowFill), and its formatted text waiting for its turn.
inline constexpr double kStreamedRowBytes = 64.0;

// Patch-level result of the fill.
struct PatchViewFactors {
  PatchMesh mesh;
  FormFactors F;              // N × N patch factors (row i = from patch i); 0 × 0 when streamed
  bool streamed = false;      // the rows went to options.row_sink
  std::string stream_reason;  // why streamed or not ("auto: ...", "requested (--stream yes)")
  FillStats fill;
  ViewFactorMemory memory;
  std::string visibility_mode;  // "none", "exact" or "rays"
  std::string visibility_reason;
  std::shared_ptr<const Visibility> visibility;  // null when visibility_mode is "none"
};

// Throws photometria::Error(BadInput) when the scene has no patch, or when the memory estimate
// exceeds the limit (one line naming both; nothing has been filled yet).
PatchViewFactors compute_view_factors(const Scene& scene, const ViewFactorOptions& options);

// The surfaces of the requested level: one entry per output row/column.
struct Aggregation {
  std::vector<std::string> names;  // group name, "face <source_face>" or "patch <i>"
  std::vector<double> areas;       // m², Σ of member patch areas
  std::vector<int> of_patch;       // per patch: index of its surface (size N), -1 for none
  // Per patch (size N, or empty when none): the surface whose factors and area this patch is
  // taken out of (a View3D subsurface's base: Face::base_group at the group level, the face of
  // that group holding the subsurface at the face level), -1 for none.
  std::vector<int> minus_of_patch;
  // Per patch (size N, or empty when none): the View3D mask surface (Face::mask_surface) the
  // patch belongs to, whose only factor is the one to its base (A_M F_MB = A_B F_BM = A_M), -1
  // for none.
  std::vector<int> mask_of_patch;
  int size() const { return static_cast<int>(names.size()); }
};
// Groups without patches (obstruction-only groups) are left out.
Aggregation make_aggregation(const Scene& scene, const PatchMesh& mesh, AggregateLevel level);
// F_IJ of the formula above; G × G.
ViewFactorMatrix aggregate(const FormFactors& F, const PatchMesh& mesh, const Aggregation& agg);
// The same, consuming F: where every surface is one patch, in patch order, and F is dense double,
// F's entries are the result, handed over without a copy (F is left 0 × 0); otherwise as above.
ViewFactorMatrix aggregate(FormFactors&& F, const PatchMesh& mesh, const Aggregation& agg);

// Checks of a view-factor matrix with surface areas `areas` (size n).
struct MatrixChecks {
  double min_row_sum = 0.0, max_row_sum = 0.0, mean_row_sum = 0.0;
  int worst_row = 0;                // row whose sum is farthest from 1
  double reciprocity_error = 0.0;   // max_{i<j} |A_i F_ij − A_j F_ji| / min(A_i, A_j)
  bool reciprocity_checked = true;  // false for streamed rows (check_rows): reciprocity_error is 0
  double min_entry = 0.0, max_entry = 0.0;
};
MatrixChecks check_matrix(const ViewFactorMatrix& F, const std::vector<double>& areas);
// The checks of rows that were never held together (streamed): from each row's sum (as
// check_matrix sums it: Eigen's sum of the row) and the extremes of all entries; the reciprocity
// error needs both triangles at once, so it is not checked (reciprocity_checked = false).
MatrixChecks check_rows(const std::vector<double>& row_sums, double min_entry, double max_entry);

enum class Enforcement { None, Reciprocity, Closure, Both };
// "none", "reciprocity", "closure", "both" (the names of `viewfactors --enforce`).
std::string enforcement_name(Enforcement mode);
// The mode named `name` (as enforcement_name) into `out`; false when unknown.
bool enforcement_from_name(const std::string& name, Enforcement& out);

struct EnforcementReport {
  MatrixChecks before, after;
  int iterations = 0;       // scaling sweeps (closure / both)
  double max_change = 0.0;  // max |F_new − F_old| over entries
};
// Modifies F in place (see viewfactors.cpp for the method and its citations):
//   reciprocity: A·F replaced by its symmetric part (the nearest symmetric matrix in the
//                Frobenius norm); row sums change by the reciprocity error only;
//   closure:     each row divided by its sum (rows with sum 0 are left alone);
//   both:        symmetric part, then symmetric diagonal scaling D (A·F) D with row sums A_i
//                (symmetric Sinkhorn–Knopp), so A·F stays symmetric and every row sums to 1.
// `tolerance`: closure iterations stop when every |row sum − 1| <= tolerance.
EnforcementReport enforce(ViewFactorMatrix& F, const std::vector<double>& areas, Enforcement mode,
                          double tolerance = 1e-14, int max_iterations = 1000);

// Hottel's total exchange factors ("script-F"; H. C. Hottel & A. F. Sarofim, "Radiative
// Transfer", McGraw-Hill, 1967, pp. 84-86; the net radiation method in matrix form: M. F. Modest,
// "Radiative Heat Transfer", 3rd ed., 2013, ch. 5) of gray, diffuse, opaque surfaces with
// emissivities ε_i (reflectance ρ_i = 1 − ε_i) from their view factors F (row i = from i):
//   sF_ij = fraction of the blackbody emission of surface i absorbed by surface j, directly and
//           after any number of diffuse reflections;
//   sF = diag(ε) X  with  (I − F diag(ρ)) X = F diag(ε),
// X_ij being the probability that radiation leaving i is eventually absorbed by j. The diagonal
// sF_ii (i's own emission it absorbs back) is in general not 0. For an enclosure (rows of F
// summing to 1) the rows of sF sum to ε_i; with reciprocal F, A_i sF_ij = A_j sF_ji. ε_i = 1
// everywhere gives sF = F; a surface with ε_i = 0 (a perfect reflector) has a zero row and column.
// This is View3D's `C emit=1` (its IntFac(), which solves the same system with the areas folded
// in; View3D clamps emissivities to [0.001, 0.999] when it reads them, this does not).
// X is solved by dense LU with partial pivoting (Eigen::PartialPivLU) of the G × G matrix.
// Throws photometria::Error(BadInput) when the sizes differ, an emissivity is outside [0, 1], or
// the system is singular (reciprocal condition number estimate below 1e-12: perfect reflectors
// closing an enclosure, where no radiation is ever absorbed) or gives a non-finite factor.
ViewFactorMatrix exchange_factors(const ViewFactorMatrix& F, const std::vector<double>& emissivities);

// A point with its unit normal (front side receives).
struct SurfacePoint {
  std::string id;
  Vec3 position = Vec3::Zero();
  Vec3 normal = Vec3::UnitZ();
};
// Points from JSON ({"points": [{"id", "position": [x,y,z], "normal": [x,y,z]}, ...]} or a bare
// array of such objects) or CSV (x,y,z,nx,ny,nz per line, optional id as a 7th column, an
// optional header line starting with a letter). Normals are normalised; zero normals refused.
std::vector<SurfacePoint> load_points(const std::string& path);

// The `emit` field of a View3D input's S and O lines, indexed by surface number − 1 (which is
// Face::source_face of the loaded scene). Call it after load_scene() accepted the file: only the
// fields are read here (comments, case and the end record as in scene/load_view3d.cpp).
std::vector<double> view3d_emissivities(const std::string& path);

// P × G: F(dA_x -> surface I) = Σ_{j∈I} F_vis(dA_x -> P_j), Lambert's closed form
// (kernels/lambert.h; M. M. Stark, "Vertex-Based Formulations of Irradiance from Polygonal
// Sources", University of Utah UUCS-00-012, 2000, eq. 3) with visibility as in the vertex gather of
// the solve (shaft culling, then exact clipping or rays). `visibility` may be null (nothing
// blocks).
ViewFactorMatrix point_view_factors(const std::vector<SurfacePoint>& points, const PatchMesh& mesh,
                                    const Aggregation& agg, const Visibility* visibility,
                                    const ViewFactorOptions& options);

}  // namespace photometria
