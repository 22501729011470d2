// Lambert's closed form for one receiver point against many polygons at once (SIMD over sources).
//
//   F(dA -> P_k) = -1/(2π) Σ_i Θ_i  N · (a_i × a_{i+1}) / |a_i × a_{i+1}|,   a_i = v_i - p,
//   Θ_i = atan2(|a_i × a_{i+1}|, a_i · a_{i+1})
// Heitz 2017 eq. (1); Stark 2000 eq. (3) (full references in lambert.h) — the formula of lambert.h,
// whose conventions (one-sided, horizon clipping, in-plane and boundary limits, atan2, edge normals
// a_i × (v_{i+1} - v_i)) hold here unchanged: lambert_form_factors() returns, polygon by polygon,
// what lambert_form_factor() returns, to rounding (≤ 1e-13 relative, or 1e-16 absolute for values
// below 1e-3; tests/test_kernels_batch.cpp).
//
// What is batched: one receiver (point, normal) against a run of source polygons of at most four
// corners, stored as a structure of arrays (PolygonBatch). This is the shape of the form-factor
// fill and of the per-vertex gather: one receiver point against all patches of a row. With AVX2
// four polygons are evaluated per instruction stream (double precision throughout), 6–8× the
// scalar kernel's rate on unclipped quads (bench/bench_kernels.cpp, run_batch/lambert_batch_*).
//
// When the scalar kernel is called instead (per polygon, with exactly its arguments, so every
// special case keeps lambert_form_factor()'s semantics):
//  - the polygon is degenerate (zero Newell vector), has fewer than 3 vertices or a non-finite
//    coordinate;
//  - some vertex lies on or below the receiver's horizon (N · a_i not clearly > 0) while not all
//    of them are clearly below it: the polygon would be clipped;
//  - the receiver is neither clearly in front of the polygon's plane nor clearly behind it (the
//    in-plane and boundary cases, and polygons seen edge-on). "Clearly" means by more than a
//    bound on the rounding of both kernels' plane tests: a few ulps of the coordinates'
//    magnitude, more for polygons that are far away or thin compared with their size;
//  - the edge terms cancel so much that the two kernels' roundings could differ by more than
//    the agreement above (Σ_i |term_i| > 1/8 and > 128·F; large polygons seen at grazing
//    incidence from close by);
//  - the CPU has no AVX2 + FMA: then every polygon goes to the scalar kernel (same results,
//    scalar speed). The AVX2 code lives in its own translation unit (lambert_batch_avx2.cpp)
//    and is reached only after a runtime CPU check, so the binary runs on any x86-64.
// Polygons that the receiver clearly sees from behind (one-sided) or that lie wholly and clearly
// below its horizon get 0 without a scalar call; that is the scalar kernel's value there too.
#pragma once

#ifndef PHOTOMETRIA_LAMBERT_BATCH_INTERNAL_ONLY  // see the end of this file

#include <array>
#include <cstddef>
#include <new>
#include <vector>

#include "kernels/lambert.h"

namespace photometria {

// std::allocator with 64-byte alignment (a cache line; any SIMD width up to AVX-512).
template <class T>
struct AlignedAllocator {
  using value_type = T;
  static constexpr std::align_val_t kAlignment{64};
  AlignedAllocator() = default;
  template <class U>
  AlignedAllocator(const AlignedAllocator<U>&) noexcept {}
  T* allocate(std::size_t n) { return static_cast<T*>(::operator new(n * sizeof(T), kAlignment)); }
  void deallocate(T* p, std::size_t) noexcept { ::operator delete(p, kAlignment); }
  template <class U>
  bool operator==(const AlignedAllocator<U>&) const noexcept {
    return true;
  }
};
using AlignedDoubles = std::vector<double, AlignedAllocator<double>>;

// Polygons of 3 or 4 corners as a structure of arrays, built by push_back() (treat the arrays as
// read-only). Every array has `padded` entries (`size` rounded up to kPadding); entry k describes
// polygon k, entries size..padded-1 are padding (zeros, kind 0). All lengths in metres.
struct PolygonBatch {
  static constexpr int kPadding = 8;  // multiple of every SIMD width in doubles (AVX-512: 8)

  int size = 0;    // number of polygons
  int padded = 0;  // size rounded up to kPadding

  // Corner c of polygon k is (x[c][k], y[c][k], z[c][k]), counter-clockwise seen from the front
  // (lambert.h). Triangles repeat corner 2 as corner 3 (a zero-length edge adds nothing).
  std::array<AlignedDoubles, 4> x, y, z;
  // Number of vertices polygon k was given with (0–4); the scalar fallback is called with that.
  std::vector<int> vertex_count;
  // 3 (triangle) or 4 (quad) for polygons the SIMD kernel may evaluate; 0 for padding and for
  // polygons that always take the scalar kernel (degenerate, < 3 vertices, non-finite).
  // Stored as double so that the SIMD kernel can compare it directly.
  AlignedDoubles kind;
  // Unit front normal (normalized Newell vector) and the vertex mean, a point on the plane.
  AlignedDoubles nx, ny, nz, ox, oy, oz;
  // For the rounding margins: max |coordinate| over the corners; max distance of a corner from
  // the vertex mean; 2·radius / |Newell vector| (1/m: ~1/radius for compact polygons, large for
  // thin ones).
  AlignedDoubles magnitude, radius, shape;

  // Shared edges (share_edges(); empty until then). Lambert's sum is over edges, and an edge two
  // polygons share adds opposite terms to them: a_i × a_{i+1}, its length and a_i · a_{i+1} do not
  // depend on the direction except for the sign of the cross product. So lambert_form_factors()
  // computes each edge's term once per receiver and chunk of kEdgeChunk polygons (about 2 per
  // quad of a mesh instead of 4), in both directions, and adds them up polygon by polygon in the
  // same order as before: the same values bit for bit.
  // Per chunk c (polygons [c·kEdgeChunk, (c + 1)·kEdgeChunk)): its distinct edges
  // [chunk_edges[c], chunk_edges[c + 1]) (a multiple of 4 each, at most kEdgeStride; padding
  // edges have zero length), edge e running from (ex[0][e], ey[0][e], ez[0][e]) to
  // (ex[1][e], ey[1][e], ez[1][e]).
  static constexpr int kEdgeChunk = 256;
  static constexpr int kEdgeStride = 4 * kEdgeChunk;
  std::array<AlignedDoubles, 2> ex, ey, ez;
  std::vector<int> chunk_edges;  // chunks + 1 entries
  // Polygon k's edge from corner c to corner c + 1 (mod 4): edge[c][k] = i for its chunk's edge
  // chunk_edges[chunk] + i run forwards, kEdgeStride + i for it run backwards. `padded` entries.
  std::array<std::vector<int>, 4> edge;

  PolygonBatch() = default;
  // From a list of polygons of 3 or 4 vertices (std::invalid_argument for more than 4; fewer
  // than 3 is accepted and gives F = 0, as in the scalar kernel).
  explicit PolygonBatch(const std::vector<Polygon>& polygons);

  void reserve(int polygons);
  // Appends one polygon (n ≤ 4 vertices, else std::invalid_argument).
  void push_back(const Vec3* polygon, int n);
  void push_back(const Polygon& polygon) { push_back(polygon.data(), static_cast<int>(polygon.size())); }

  // Polygon k's vertices as given (vertex_count[k] of them) into `v`; returns their number.
  int vertices(int k, Vec3 v[4]) const;

  // Finds the edges shared within each chunk (equal end points, either direction; polygons of
  // kind 0 share none) and fills the tables above. Call after the last push_back(), which
  // forgets them.
  void share_edges();
  bool edges_shared() const { return !chunk_edges.empty(); }
};

// out[k - begin] = lambert_form_factor(receiver, polygon k) for k in [begin, end),
// 0 <= begin <= end <= sources.size (std::out_of_range otherwise). Dimensionless, each in
// [0, 1]. `receiver.normal` is unit length; `receiver.approach` matters only for the boundary
// limits (scalar path). `out` holds end - begin doubles (any alignment). Returns how many of the
// polygons were handed to the scalar kernel (see above; all of them without AVX2) — a
// diagnostic, the values do not depend on it. Thread-safe (no shared state besides the scalar
// kernel's thread-local scratch).
int lambert_form_factors(const Receiver& receiver, const PolygonBatch& sources, int begin, int end, double* out);
inline int lambert_form_factors(const Receiver& receiver, const PolygonBatch& sources, double* out) {
  return lambert_form_factors(receiver, sources, 0, sources.size, out);
}

// The edge sum of the scalar kernels (Heitz 2017 eq. 1, Stark 2000 eq. 3):
//   Σ_{k<n} Θ_k proj[k] / len_k,  len_k = √len2[k],  Θ_k = atan2(len_k, dot[k]),
// with len2[k] = |a_k × a_{k+1}|², dot[k] = a_k · a_{k+1}, proj[k] = N · (a_k × a_{k+1}); a term
// with len2[k] = 0 (zero-length edge, or p on the edge's line) adds nothing. The square roots,
// angles and quotients are taken four at a time with the batched kernel's atan2 (AVX2, within
// 0.65 ulp) where the CPU has it, else with std::atan2; the terms are added in order k = 0, 1, …
// either way, so the sum is the batched kernel's bit for bit.
double edge_term_sum(const double* len2, const double* dot, const double* proj, int n);

// edge_term_sum() of a closed polygon of n = 3 or 4 vertices a_k = (x[k], y[k], z[k]) relative
// to the receiver (arrays of 4; x[3] etc. unused when n = 3), receiver normal N: the edge
// normals on the shorter vertex vector, their lengths, the dot products and the terms all in
// AVX2 lanes, one edge a lane, the same operations as edge_angle_sum() (visible_polygon.h) so
// the same value bit for bit. False (and `sum` untouched) when the CPU has no AVX2.
bool small_polygon_edge_sum(const double* x, const double* y, const double* z, int n, const double* N, double& sum);

// The SIMD instruction set lambert_form_factors() uses on this CPU: "avx2" or "scalar".
const char* lambert_batch_isa();

namespace lambert_batch_detail {
// For tests: the batched kernel's atan2(y, x) for y >= 0 (lambert_batch_avx2.cpp, AVX2 + FMA),
// and xsimd::atan2 for comparison, applied to n pairs; false (and `out` untouched) when this CPU
// or build has no AVX2 path.
bool simd_atan2(const double* y, const double* x, double* out, int n);
bool xsimd_atan2(const double* y, const double* x, double* out, int n);
// For tests and benchmarks: false makes lambert_form_factors() take the scalar kernel for every
// polygon, as on a CPU without AVX2 (default true; affects all threads).
void set_simd_enabled(bool enabled);
}  // namespace lambert_batch_detail

}  // namespace photometria

#endif  // PHOTOMETRIA_LAMBERT_BATCH_INTERNAL_ONLY

// Internal: the interface of the per-ISA translation units. Plain pointers and numbers only, so
// that lambert_batch_avx2.cpp can include just this part (it defines
// PHOTOMETRIA_LAMBERT_BATCH_INTERNAL_ONLY) and compile no Eigen or STL code with -mavx2.
namespace photometria::lambert_batch_detail {
inline constexpr int kPadding = 8;  // = PolygonBatch::kPadding
// PolygonBatch's arrays and the receiver, as lambert_batch.cpp hands them over.
struct View {
  const double* x[4];
  const double* y[4];
  const double* z[4];
  const double *kind, *nx, *ny, *nz, *ox, *oy, *oz, *magnitude, *radius, *shape;
  double p[3], n[3];   // receiver point and normal
  double p_magnitude;  // max |p coordinate|
  // Shared edges (PolygonBatch::share_edges), or null: then every polygon sums its own edges.
  int size;  // number of polygons
  const double *ex[2], *ey[2], *ez[2];
  const int* chunk_edges;
  const int* edge[4];
};
inline constexpr int kEdgeChunk = 256;              // = PolygonBatch::kEdgeChunk
inline constexpr int kEdgeStride = 4 * kEdgeChunk;  // = PolygonBatch::kEdgeStride
// Writes out[k - begin] for k in [begin, end) — the form factor, or 0 — and the indices k whose
// value the scalar kernel must supply into scalar_lanes (end - begin entries suffice); returns
// how many there are. [begin, end) lies within one chunk of kEdgeChunk polygons; when it is the
// whole chunk and the view has shared edges, each of the chunk's edges is evaluated once.
int lambert_avx2(const View& view, int begin, int end, double* out, int* scalar_lanes);
bool simd_atan2_avx2(const double* y, const double* x, double* out, int n);
// Θ_k proj[k] / √len2[k] (0 where len2[k] = 0) into out[k], k < n.
void edge_terms_avx2(const double* len2, const double* dot, const double* proj, double* out, int n);
bool xsimd_atan2_avx2(const double* y, const double* x, double* out, int n);
double small_polygon_edge_sum_avx2(const double* x, const double* y, const double* z, int n, const double* N);
bool avx2_compiled();  // false when the AVX2 file was built without -mavx2 (not x86-64)
}  // namespace photometria::lambert_batch_detail
