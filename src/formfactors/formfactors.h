// Form-factor assembly: F_ij from patch i to patch j for every pair of patches.
//
// Kernel evaluations are batched: Lambert's kernel from one receiver point to every patch is one
// SIMD call (kernels/lambert_batch.h), identical to the scalar kernel to rounding.
//
//   F_ij = Σ_q w_q F_vis(x_q -> P_j),   F_vis(x -> P) = visible part of F(dA_x -> P)
// with F(dA -> P) Lambert's closed form (kernels/lambert.h), x_q, w_q the receiver quadrature on
// patch i (formfactors/quadrature.h) and F_vis from visibility/visibility.h per receiver point:
// unoccluded when the shaft of (patch i, patch j) meets no face, else by rays (F · V(x_q, P_j)) or
// exactly (Lambert over the visible fragments). Pairs that face away from each other are skipped
// without evaluation: if patch j lies wholly on or below patch i's plane, or patch i wholly on or
// behind patch j's plane, F_ij = 0 (one-sided emission and reception).
//
// Row sums. For one receiver point the visible parts of all patches are disjoint pieces of its
// hemisphere, so Σ_j F_vis(x -> P_j) <= 1 (= 1 in a closed room), and so is every row's weighted
// sum over q. The exact mode keeps this to rounding. Ray estimates of V carry sampling noise that
// can push a point's sum above 1; each point's ray-estimated contributions are then scaled down
// so that its sum is 1 (the nearest point of the constraint along that direction; the change is
// of the order of the ray error and is reported as max_point_row_sum).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <functional>

#include "formfactors/storage.h"
#include "kernels/lambert_batch.h"
#include "patching/patching.h"
#include "visibility/visibility.h"

namespace photometria {

struct FillOptions {
  int quadrature = 1;            // receiver rule order (1 = centroid)
  double tolerance = 0.0;        // > 0: per-pair rule to this relative accuracy
                                 // (formfactors/pair_integration.h) for pairs no
                                 // face can block (an empty shaft), and the exact
                                 // closed form for pairs of aligned rectangles
                                 // (formfactors/aligned_rectangles.h); 0: the fixed
                                 // `quadrature` rule for every pair
  bool exact_rectangles = true;  // with tolerance > 0: use the rectangle closed form
                                 // (false: the per-pair rule there too, for studies)
  // > 0 with tolerance > 0 and exact visibility: the pairs of a row with occluders in their shaft
  // are integrated together, adaptively, so that the estimated error of their sum (what the row
  // sum may be off, dimensionless) is at most this (formfactors/occluded_row.h), each row spending
  // at most occluded_budget (receiver point, source) evaluations; 0: the fixed `quadrature` rule
  // with exact visibility per point.
  double occluded_tolerance = 0.0;
  long long occluded_budget = 20000000;
  const Visibility* visibility = nullptr;  // null: no occlusion test (every pair unoccluded)
  int rays = kAdaptiveRays;                // rays per (receiver point, source patch) in ray mode
                                           // (kAdaptiveRays: as the Visibility's RaySampling asks)
  uint64_t seed = 1;                       // ray sampling seed (results repeat for a seed)
  std::function<void(double)> progress;    // called with the fraction done (from one thread)
  // Optional: each finished row i (its n entries F_ij) is handed to row_sink(i, row) instead of
  // being stored, from the thread that filled it (concurrently for distinct rows, in no set
  // order); fill_form_factors() then returns a 0 × 0 matrix. What streams a matrix too large to
  // hold (viewfactors --format sparse). The sink must not throw; it returns false to stop the
  // fill (the rows not started yet are skipped: a failed write ends a long run early).
  std::function<bool(int, const double*)> row_sink;
  // With row_sink, for a scene that needs no visibility and has closed forms (tolerance > 0): the
  // bytes the fill may hold so that each closed form is computed once per pair, as in a stored
  // fill, instead of once per entry. The rows then reach row_sink in bands, band after band, and
  // the fill holds the closed forms of the bands not yet written: at most
  // streamed_mirror_peak_bytes(n). 0 (or less than that peak): every entry computed in its row.
  double streamed_mirror_bytes = 0.0;
  // Optional: only these rows (receiver patches, each once) are filled, in this order as far as
  // the threads allow; the others stay zero (a stored matrix) or never reach row_sink. What one
  // rank of an MPI run fills (distributed/row_partition.h). Null: every row.
  const std::vector<int>* rows = nullptr;
  // Storage of the result (formfactors/storage.h); Auto is resolved by the caller from the
  // expected non-zero count (pipeline/memory.h), here it means dense.
  MatrixLayout layout = MatrixLayout::Dense;
  MatrixPrecision precision = MatrixPrecision::Double;
};

struct FillStats {
  long long pairs_evaluated = 0;      // pairs whose kernel was evaluated
  long long pairs_backfacing = 0;     // skipped: facing away or coplanar
  long long pairs_tested = 0;         // evaluated, F > 0, visibility on: shaft tested
  long long pairs_culled = 0;         // of those (or all, when the scene is convex): no face in the shaft
  long long pairs_occluded = 0;       // evaluated, then found fully blocked
  long long pairs_blocked_whole = 0;  // per-pair mode: of those, blocked whole by one occluder (no rule needed)
  long long rays_cast = 0;
  long long above_unoccluded = 0;        // pairs with F_ij > F_ij unoccluded (must stay 0)
  double max_point_row_sum = 0.0;        // largest Σ_j F_vis(x_q -> P_j) over receiver points, before scaling
  long long points_rescaled = 0;         // receiver points whose ray-estimated sum exceeded 1 and was scaled
  long long pairs_fixed_rule = 0;        // pairs integrated with the fixed `quadrature` rule
  long long pairs_gauss = 0;             // per-pair rule: far pairs, Gauss order from the distance ratio
  long long pairs_adaptive = 0;          // per-pair rule: near or touching pairs, adaptive bisection
  long long pairs_exact_rectangles = 0;  // per-pair mode: aligned rectangles, closed form (exact)
  long long kernel_evaluations = 0;
  long long pairs_occluded_adaptive = 0;    // occluded pairs integrated to occluded_tolerance
  long long occluded_evaluations = 0;       // their (receiver point, source) exact visible factors
  long long occluded_budget_exhausted = 0;  // rows stopped by the budget above the tolerance
  double max_row_error_estimate = 0.0;      // max over rows of the occluded pairs' estimated error
  double max_row_ray_error = 0.0;           // ray mode: max over rows of the estimated standard error of
                                            // the row sum from ray sampling (visibility.h RaySampling)
  bool mirrored = false;                    // closed forms computed once per pair, the other entry by reciprocity
                                            // (stored rows, or rows streamed in bands: streamed_mirror_bytes)
  // Rows streamed in bands, which hold both triangles for a while: max over pairs of
  // |A_i F_ij − A_j F_ji| / min(A_i, A_j) with the patch areas, as check_form_factors gives for a
  // stored matrix. Negative: not checked (stored, or rows streamed one at a time).
  double streamed_reciprocity_error = -1.0;
};

// The invariants of a filled matrix (checked in tests and reported in the summary).
struct FormFactorChecks {
  double min_entry = 0.0, max_entry = 0.0;      // over all i != j; must lie in [0, 1]
  double min_row_sum = 0.0, max_row_sum = 0.0;  // Σ_j F_ij; <= 1, and 1 in a closed scene
  double reciprocity_error = 0.0;               // max over pairs |A_i F_ij − A_j F_ji| / min(A_i, A_j)
};
FormFactorChecks check_form_factors(const PatchMesh& mesh, const FormFactors& F);

// True when the pair (receiver i, source j) cannot exchange light: j on/below i's plane or i
// on/behind j's plane (with a tolerance of `tol` metres). Inline: the fill asks it of every pair.
inline bool facing_away(const PatchMesh& mesh, int i, int j, double tol) {
  const Patch& a = mesh.patches[size_t(i)];
  const Patch& b = mesh.patches[size_t(j)];
  double above_a = -1.0, front_of_b = -1.0;
  for (int k = 0; k < b.corner_count; ++k)
    above_a = std::max(above_a, a.normal.dot(mesh.points[size_t(b.corners[size_t(k)])] - a.centroid));
  if (above_a <= tol) return true;
  for (int k = 0; k < a.corner_count; ++k)
    front_of_b = std::max(front_of_b, b.normal.dot(mesh.points[size_t(a.corners[size_t(k)])] - b.centroid));
  return front_of_b <= tol;
}

// The vertex gather's test (pipeline/solve.cpp): true when source j cannot light the point x with
// unit normal `normal`: j wholly on or below x's plane, or x behind j's plane by more than `tol`.
inline bool point_facing_away(const PatchMesh& mesh, const Vec3& x, const Vec3& normal, int j, double tol) {
  const Patch& b = mesh.patches[size_t(j)];
  double above = -1.0;
  for (int k = 0; k < b.corner_count; ++k)
    above = std::max(above, normal.dot(mesh.points[size_t(b.corners[size_t(k)])] - x));
  return above <= tol || b.normal.dot(x - b.centroid) < -tol;
}

// Rows are computed into a per-thread dense buffer and stored with FormFactors::set_row (or handed
// to options.row_sink), so the matrix never exists in a larger layout than the one asked for.
FormFactors fill_form_factors(const PatchMesh& mesh, const FillOptions& options, FillStats& stats);

// The most a streamed, mirrored fill of n patches holds (FillOptions::streamed_mirror_bytes): the
// closed forms of the bands not yet written (at most n²/4 entries) and the band in flight.
double streamed_mirror_peak_bytes(int n);

// Every patch of `mesh` as one SIMD batch of source polygons (kernels/lambert_batch.h).
PolygonBatch patch_batch(const PatchMesh& mesh);

// Geometric tolerance for plane tests: a few ulps of the scene's size.
double plane_tolerance(const PatchMesh& mesh);

}  // namespace photometria
