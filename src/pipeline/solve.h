// The main job: scene -> patches -> form factors -> radiosity -> per-vertex results.
//
// solve_scene() runs every stage, skips what the scene does not need (visibility in a convex
// enclosure, back-facing pairs, two colour channels when all materials are grey) and records
// what it did in SolveSummary. Per-vertex values follow Baum, Rushmeier & Winget 1989: the
// irradiance is gathered at the vertex itself from the converged patch radiosities,
//   H(x) = Σ_j F(dA_x -> P_j) V(x, P_j) B_j,   B(x) = E + ρ H(x),
// not averaged from neighbouring cells. Output points are split where faces meet at a crease
// (OBJ vn that differ, else across smoothing groups, else sharper than the crease angle) or a
// material change, so every point has one normal and one material; faces meeting smoothly share
// a point.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "formfactors/formfactors.h"
#include "hierarchical/hierarchical.h"
#include "patching/patching.h"
#include "pipeline/memory.h"
#include "scene/scene.h"
#include "solver/gauss_seidel.h"
#include "visibility/choice.h"

namespace photometria {

// How the radiosity is solved: the dense N × N form-factor matrix (exact per pair, memory N²),
// or hierarchical radiosity (hierarchical/hierarchical.h: links refined to an error ε, memory
// following the links), or Auto: dense when its memory estimate fits the limit (--max-memory or
// MemAvailable), else hierarchical (on rooms of a few faces the dense method is the faster:
// docs/performance.md "Hierarchical radiosity").
enum class SolveMethod { Dense, Hierarchical, Auto };
// "dense", "hierarchical", "auto" (the names of `solve --method`).
std::string solve_method_name(SolveMethod method);
// The method named `name` into `out`; false when unknown.
bool solve_method_from_name(const std::string& name, SolveMethod& out);

struct SolveOptions {
  SolveMethod method = SolveMethod::Dense;
  // Hierarchical method: ε (HierarchicalOptions::error) and the smallest element's longest edge
  // (metres; 0 = 1/256 of the bounding diagonal). Its roots are the scene's faces; `patching`
  // is the dense method's.
  double hierarchical_error = 1e-2;
  double min_element_edge = 0.0;
  int cluster_above = 512;   // HierarchicalOptions::cluster_above
  PatchingOptions patching;  // patch size limits
  int quadrature = 1;        // receiver rule order, 1 = centroid
  double accuracy = 0.0;     // > 0: per-pair rule to this relative accuracy for
                             // pairs nothing can block (formfactors/pair_integration.h)
  VisibilityMode visibility = VisibilityMode::Auto;
  int rays = kAdaptiveRays;  // rays per (receiver point, patch) in ray mode (fill and vertex gather);
                             // kAdaptiveRays: until the estimated error meets `accuracy` (else 1e-2)
  uint64_t seed = 1;         // ray sampling seed
  // Output points (Baum et al. 1989 vertex gather): patches meeting at a vertex share one point,
  // with their angle-weighted mean normal, when their normals differ by less than this angle
  // (degrees, in [0, 180); 0: only coplanar patches share, every crease is sharp). The same
  // material is required. What the file says wins over the angle, in this order: where both
  // corners carry an OBJ vn (Face::corner_normals, interpolated along edges and inside faces),
  // they share iff the vn are equal, and a point whose corners all carry one takes it as its
  // normal; else smoothing groups (Face::smoothing_group) decide where the file gave them.
  // A vn pointing into the back of its face is not used (that corner counts as without one).
  double crease_angle_degrees = 30.0;
  SolverOptions solver;
  int threads = 0;  // 0 = all cores
  // Refuse (BadInput) before the form-factor fill when the estimated memory (pipeline/memory.h,
  // the storage actually used) exceeds this many bytes; 0 = MemAvailable from /proc/meminfo.
  double max_memory_bytes = 0.0;
  // Form-factor storage (formfactors/storage.h, chosen by pipeline/memory.h choose_storage):
  // layout Auto = dense or sparse, whichever the estimated non-zero count makes smaller;
  // float halves the matrix (entries rounded to 2^-24 relative); precision Auto = double
  // unless only float fits the memory limit (the summary says so).
  MatrixLayout matrix_layout = MatrixLayout::Auto;
  MatrixPrecision matrix_precision = MatrixPrecision::Auto;
  // Optional: called with a stage ("form factors", "vertex gather") and its fraction done (0..1,
  // ending with 1), from one thread at a time (util/progress.h shows it).
  std::function<void(const std::string& stage, double fraction)> progress;
};

struct EnergyBalance {
  Rgb emitted = Rgb::Zero();    // Σ A_i E_i, W
  Rgb direct_in = Rgb::Zero();  // Σ A_i H_direct,i: arriving from analytic lights, W
  Rgb absorbed = Rgb::Zero();   // Σ A_i (1 − ρ_i) H_i, W
  Rgb escaped = Rgb::Zero();    // Σ A_i B_i (1 − Σ_j F_ij): leaves through openings, W
  double relative_imbalance =
      0.0;  // max over channels |emitted + direct_in − absorbed − escaped| / (emitted + direct_in)
};

struct SolveSummary {
  std::string method;              // "dense" or "hierarchical" (SolveOptions::method, Auto resolved)
  std::string method_reason;       // "requested (--method dense)" or "auto: <why>"
  HierarchicalStats hierarchical;  // the hierarchical method's statistics (method "hierarchical")
  int faces = 0;
  int patches = 0;
  double min_patch_area = 0.0, max_patch_area = 0.0, total_area = 0.0;
  long long pairs_total = 0;  // N (N − 1)
  FillStats fill;
  FormFactorChecks checks;        // invariants of the filled matrix
  std::string visibility_mode;    // "none", "rays" or "exact"
  std::string visibility_reason;  // why that mode was chosen
  int quadrature = 1;
  double accuracy = 0.0;
  int lights = 0;            // analytic lights in the scene file (0: the direct-light pass is skipped)
  std::string ray_sampling;  // ray mode: ray_sampling_name (visibility/choice.h); else empty
  SolverReport solver;
  double tolerance = 0.0;
  int output_points = 0;
  double crease_angle_degrees = 0.0;  // SolveOptions::crease_angle_degrees used
  long long vertex_pairs_evaluated = 0;
  long long vertex_rays_cast = 0;
  long long vertex_pairs_tested = 0, vertex_pairs_culled = 0;  // shaft tests in the gather
  std::string matrix_storage;                                  // "dense double", "sparse float", ... (what was used)
  std::string matrix_storage_reason;                           // why (requested, or auto from the estimate)
  double matrix_bytes = 0.0;                                   // bytes of the stored matrix (after the fill)
  double estimated_bytes = 0.0;                                // the estimate the memory limit was checked against
  MemoryEstimate memory;                                       // estimated before the fill
  double memory_limit_bytes = 0.0;
  std::string memory_limit_source;  // "--max-memory" or "MemAvailable"
  int threads = 1;                  // per process (per rank on MPI ranks)
  // On MPI ranks (distributed/ranks.h): their count, the rows of F each held and filled, and the
  // seconds each rank's fill took. One process: 1, empty, empty.
  int ranks = 1;
  std::vector<int> rows_per_rank;
  std::vector<double> fill_seconds_per_rank;
  std::vector<std::pair<std::string, double>> stage_seconds;
  EnergyBalance energy;
};

struct OutputPoint {
  Vec3 position;
  Vec3 normal;
  Vec3 approach;  // unit direction in the tangent plane towards the point's own patches
  int material = 0;
};

struct SolveResult {
  PatchMesh mesh;
  ChannelMatrix emission, reflectance, irradiance, radiosity;  // per patch, N × 3
  std::vector<OutputPoint> points;                             // split output points
  std::vector<std::vector<int>> cells;                         // per patch: indices into points
  ChannelMatrix point_irradiance, point_radiosity;             // per output point, P × 3
  SolveSummary summary;
};

// Throws photometria::Error: BadInput when there is nothing to solve (no emitter), a material
// is out of range or the memory estimate exceeds the limit (options.max_memory_bytes), NotConverged when the solver
// hits its iteration cap.
SolveResult solve_scene(const Scene& scene, const SolveOptions& options);

// Peak resident memory of this process so far, bytes.
double peak_memory_bytes();

}  // namespace photometria
