// Exact patch-to-patch form factors between axis-aligned rectangles (rectilinear rooms).
//
// For two rectangles whose edges run along the axes of one orthonormal frame, on planes that
// are parallel or perpendicular, the form factor has a closed form by superposition of Howell's
// catalog cases C-11 (parallel rectangles) and C-14 (perpendicular rectangles with a common
// edge) — J. R. Howell, "A Catalog of Radiation Heat Transfer Configuration Factors", 3rd ed. —
// written out as in Ehlert & Smith, "View factors for perpendicular and parallel rectangular
// plates", J. Thermophysics Heat Transfer 7(1), 1993, eqs. 3–6:
//
//   parallel planes a distance z apart, P = [x0,x1]×[y0,y1], Q = [ξ0,ξ1]×[η0,η1] in common
//   in-plane coordinates:
//     A_P F_PQ = (1/2π) Σ_{ijkl} (−1)^{i+j+k+l} Gp(x_i − ξ_k, y_j − η_l, z)
//     Gp(x, y, z) = x √(y²+z²) atan(x/√(y²+z²)) + y √(x²+z²) atan(y/√(x²+z²)) − (z²/2) ln(x²+y²+z²)
//   perpendicular planes, x along the common axis, y (on P) and η (on Q) the distances from
//   the planes' common line, y0 < y1, η0 < η1:
//     A_P F_PQ = (1/2π) Σ_{ijkl} (−1)^{i+j+k+l} Gq(x_i − ξ_k, y_j, η_l)
//     Gq(x, y, η) = x √(y²+η²) atan(x/√(y²+η²)) − ¼ (y² + η² − x²) ln(x² + y² + η²)
//
// A_P F_PQ is symmetric in P and Q (reciprocity), so one evaluation serves F_ij and F_ji; this
// class returns the area factor A_i F_ij (m²), F_ij = area_factor(i, j) / A_i, and returns the
// bit-identical value for (j, i).
//
// Speed. Patches are grouped by frame and by plane; for every pair of planes that exchange
// light the constructor tabulates the corner function over the distinct coordinate
// differences: Gp and Gq are even in their first argument, and the differences are formed in
// long double from the coordinates (deduplicated by exact equality, never rounded to double
// first), so a uniform n × n grid against another has only n + 1 distinct |x_i − ξ_k|. Plane
// pairs with identical argument lists share one set of corner functions (the 12 perpendicular
// wall pairs of a cube). Where the patches of a plane form few distinct intervals per axis
// (grids), the inner 2 × 2 part of the alternating sum is stored per (|x − ξ|, interval of P,
// interval of Q) — the "interval form", 4 reads per pair, the path inlined below; otherwise the
// "corner form", 16 reads. Plane pairs whose tables would exceed `max_table_bytes`, or would
// hold more values than the pairs they serve (4 per pair in the corner form), are evaluated
// directly with the same formula (16 corner functions per call, about 2 µs). On the unit cube
// with 32 × 32 patches per wall (N = 6,144; 15 interval tables, 8.2 MB) the constructor takes
// about 20 ms and area_factor about 10–15 ns per pair on one core (bench/bench_rectangles.cpp).
// A rotated room is exact too, but its coordinate differences no longer coincide, so its
// tables are corner form and larger (42 MB, 0.3 s to build at 32 × 32).
//
// Accuracy. The 16-term sum cancels: its terms are O(d²), the result O(s⁴/d²) for patches of
// size s a distance d apart. Corner functions and the inner sums are evaluated in long double
// (x87 extended, 64-bit mantissa, relative rounding 5.4e-20); the interval form stores each
// long double exactly as two doubles (hi + lo), and the outer 2 × 2 sum adds the hi parts, then
// the lo parts (exact where it cancels: the four values then agree within a factor 2), which
// keeps the long double accuracy without x87 loads in the hot path. What is left is the
// rounding of the corner functions: an error of about 1e-19 d² in A F, i.e. a relative error of
// about 1e-19 (d/s)⁴. Measured (tests/test_formfactors_rectangles.cpp): <= 4e-15 on every pair
// of an 8 × 8 cube; at 32 × 32 median 1e-16, 99th percentile 1e-13, max 4e-12 (F > 1e-6); at
// 64 × 64 max 3e-11; absolute error of F below 4e-16 throughout. Tables, corner form and direct
// evaluation give bit-identical results; so do area_factor(i, j) and (j, i).
// The geometry the formula sees: each rectangle is replaced by the box spanned by its corners'
// coordinates in the frame, coordinates closer than 1e-12 × (largest |coordinate| of the mesh)
// along a frame axis being merged into one (that also puts a patch edge lying on another
// patch's plane exactly on it). For the input rectangles (right angles to 1e-12) that moves an
// edge by no more than the input's own deviation from an exact rectangle.
//
// Not here: occlusion (the factors are unoccluded, for convex rooms or as the unoccluded part
// of a visibility computation) and pairs of different frames (not eligible).
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <unordered_map>
#include <utility>
#include <vector>

#include "patching/patching.h"

namespace photometria {

class AlignedRectangles {
 public:
  // Classifies the patches of `mesh` and builds the tables (OpenMP parallel over table rows).
  // The mesh is copied from as needed; it need not outlive this object. `max_table_bytes`
  // bounds table_bytes(); 0 means no tables (every pair evaluated directly).
  explicit AlignedRectangles(const PatchMesh& mesh, std::size_t max_table_bytes = std::size_t(256) << 20);

  // True if patch i is a rectangle with edges along the axes of a frame: 4 corners,
  // opposite sides equal and adjacent sides at right angles to 1e-12 relative (plus the
  // rounding of the coordinates' magnitude), corners counter-clockwise around its `normal`,
  // sides longer than 1e-9 × the largest |coordinate| of the mesh.
  bool is_rectangle(int i) const { return rects_[i].frame >= 0; }

  // True if the pair (i, j) has a closed form here: both patches are rectangles whose edges lie
  // along the axes of one common orthonormal frame (to 1e-12 in angle). Patches are grouped by
  // frame, so a rotated room qualifies as well as a world-aligned one; two such rectangles lie
  // on parallel or perpendicular planes. eligible(i, i) is true for a rectangle (factor 0).
  bool eligible(int i, int j) const { return rects_[i].frame >= 0 && rects_[i].frame == rects_[j].frame; }

  // A_i F_ij in m²: the exact unoccluded area-weighted form factor between patches i and j,
  // one-sided: light leaves and arrives only through the fronts (Patch::normal side).
  //  - parallel planes: nonzero only if the planes face each other (coplanar pairs give 0);
  //  - perpendicular planes: only the part of each rectangle in front of the other's plane takes
  //    part (each is clipped at the common line, so a wall patch crossing a table top's plane
  //    exchanges only through its part above the top); a pair wholly behind gives exactly 0.
  // Symmetric to the last bit: area_factor(i, j) == area_factor(j, i). Requires eligible(i, j)
  // (otherwise the result is NaN). Thread-safe (const, no shared mutable state).
  double area_factor(int i, int j) const;

  // Bytes held by the tables, their index maps and the plane-pair index (<= max_table_bytes).
  std::size_t table_bytes() const { return table_bytes_; }

  struct Summary {
    int rectangles = 0;                    // eligible patches
    int frames = 0;                        // distinct frames among them
    int planes = 0;                        // distinct (frame, normal axis, side, offset)
    long long plane_pairs_exchanging = 0;  // plane pairs that can exchange light
    int tables_interval = 0;               // of those: tabulated with 4 reads per pair
    int tables_corner = 0;                 // tabulated with 16 reads per pair
    long long table_entries = 0;           // values stored (16 bytes each)
  };
  const Summary& summary() const { return summary_; }

 private:
  // Per patch (hot data). A plane's two in-plane axes are "slots": slot s is frame axis
  // (normal axis + 1 + s) mod 3.
  struct Rect {
    int32_t frame = -1;                  // -1: not an aligned rectangle
    int32_t plane = -1;                  // global plane id (planes of one frame are consecutive)
    int32_t lplane = -1;                 // plane index within its frame
    int32_t l[2][2] = {{0, 0}, {0, 0}};  // per slot: local coordinate index of the low / high edge
    int32_t r[2] = {0, 0};               // per slot: interval id (distinct (low, high) pairs)
  };
  struct Plane {
    int frame = 0, axis = 0, sign = 1;                      // normal = sign × frame axis `axis`
    int32_t offset = 0;                                     // coordinate index of the plane along `axis`
    std::vector<int32_t> coords[2];                         // per slot: frame coordinate indices used, increasing
    std::vector<std::pair<int32_t, int32_t>> intervals[2];  // per slot: (low, high) local indices
    long long patches = 0;
  };
  struct Frame {
    Vec3 axis[3];
    std::vector<double> coord[3];  // merged coordinates along each axis, increasing
    int first_plane = 0, planes = 0;
    bool dense = true;  // pair ids in a planes × planes matrix, else in a hash map
    std::vector<int32_t> pair_ids;
    std::unordered_map<uint64_t, int32_t> pair_map;
  };
  enum : int32_t { kNone = -1, kDirect = -2 };  // pair ids that are not tables
  // Tables of one plane pair (P, Q), P the lower plane id. "Outer" is the axis along which the
  // corner functions take differences |x_i − ξ_k| (parallel: slot 0; perpendicular: the common
  // axis); "inner" the other in-plane axis of each plane.
  struct Table {
    bool parallel = true;
    bool intervals = false;  // values per (|x − ξ|, P interval, Q interval): 4 reads per pair
    int p_outer = 0, q_outer = 0, p_inner = 1, q_inner = 1;  // slots
    int32_t nq_outer = 0;                                    // Q's coordinate count on its outer slot
    std::vector<int32_t> outer;  // [P coord × Q coord] → offset of the |x − ξ| block in values
    // Corner form (16 reads): parallel: inner[P coord × Q coord] → |y − η| id;
    // perpendicular: inner[P coord] → offset of P's distance y, inner[q_base + Q coord] → η id.
    std::vector<int32_t> inner;
    int32_t nq_inner = 0, q_base = 0, zero_p = 0, zero_q = 0;
    int flip_p = 0, flip_q = 0;  // 1: distance decreases with the coordinate
    int32_t nr_q = 0;            // interval form: Q's interval count on its inner slot
    // Interval form: the inner sums (long double values, each stored exactly as hi, lo doubles).
    std::vector<double> interval_values;
    // Corner form: the corner functions, shared by plane pairs with the same argument lists.
    std::shared_ptr<const std::vector<long double>> corner_values;
    const long double* corner = nullptr;
  };

  double corner_form(const Table& t, const Rect& p, const Rect& q) const;
  double direct(const Rect& p, const Rect& q) const;

  // The constructor's steps, in order (aligned_rectangles.cpp), and what passes between them.
  struct Raw;        // a patch's classification, before coordinates are merged
  struct Candidate;  // a plane pair that exchanges light, worth a table
  struct Build;      // what a table's values need beyond the Table (freed after the build)
  struct Group;      // corner functions shared by builds with the same argument lists
  void classify(const PatchMesh& mesh, double scale, std::vector<Raw>& raw);                  // 1. rectangles, frames
  void merge_coordinates(std::vector<Raw>& raw, double merge_tol);                            // 2. coordinates
  void make_planes(const std::vector<Raw>& raw);                                              // 3. planes
  std::vector<Candidate> exchanging_pairs(std::size_t max_table_bytes, std::size_t& budget);  // 4a.
  std::vector<Build> plan_tables(const std::vector<Candidate>& candidates, std::size_t& budget);      // 4b.
  std::vector<Group> share_corner_functions(std::vector<Build>& builds);                              // 5a.
  void compute_corner_functions(const std::vector<Build>& builds, const std::vector<Group>& groups);  // 5b.
  void compute_interval_sums(const std::vector<Build>& builds, const std::vector<Group>& groups);     // 5c.
  void count_kept(const std::vector<Group>& groups);                                                  // 5d.
  bool take(std::size_t& budget, std::size_t bytes);  // charges bytes to the budget if they fit

  std::vector<Rect> rects_;
  std::vector<Plane> planes_;
  std::vector<Frame> frames_;
  std::vector<Table> tables_;
  std::size_t table_bytes_ = 0;
  Summary summary_;
};

// The same closed form for one pair, without a mesh (a link between two elements of the
// hierarchical method): A_P F_PQ in m², one-sided as area_factor(), when P and Q (4 corners each,
// counter-clockwise around their unit normals) are rectangles whose sides run along the axes of
// one orthonormal frame (P's sides, to 1e-12 relative); returns false, writing nothing,
// otherwise. Coordinates are not merged (area_factor merges those closer than 1e-12 of the
// mesh's size): a P edge lying in Q's plane to rounding gives the same factor to rounding.
bool aligned_rectangle_pair(const Vec3 p[4], const Vec3& p_normal, const Vec3 q[4], const Vec3& q_normal,
                            double& area_factor);

namespace aligned_rectangles_detail {
// ((a − b) − (c − d)) / 2π for four long double values each held exactly as hi + lo doubles: the
// hi parts first, then the lo parts, then one rounding. Where the sum cancels (far pairs) the
// four values agree to within a factor 2, so the hi differences are exact (Sterbenz) and the
// result keeps the inputs' long double accuracy; elsewhere there is no cancellation to amplify
// the double roundings. Clamped at 0: a form factor, only rounding can make it negative.
inline double combine(const double* a, const double* b, const double* c, const double* d) {
  const double hi = (a[0] - b[0]) - (c[0] - d[0]);
  const double lo = (a[1] - b[1]) - (c[1] - d[1]);
  const double f = (hi + lo) * 0.15915494309189533577;  // 1/(2π)
  return f > 0.0 ? f : 0.0;
}
}  // namespace aligned_rectangles_detail

// The hot path (inline: the fill calls it ~N²/2 times): the plane-pair lookup and the interval
// form; the corner form and direct evaluation are out of line.
inline double AlignedRectangles::area_factor(int i, int j) const {
  const Rect* p = &rects_[i];
  const Rect* q = &rects_[j];
  if (p->frame < 0 || p->frame != q->frame) return std::numeric_limits<double>::quiet_NaN();
  if (p->plane == q->plane) return 0.0;
  if (p->plane > q->plane) std::swap(p, q);
  const Frame& fr = frames_[p->frame];
  int32_t id;
  if (fr.dense) {
    id = fr.pair_ids[static_cast<std::size_t>(p->lplane) * fr.planes + q->lplane];
  } else {
    const auto it = fr.pair_map.find((uint64_t(p->lplane) << 32) | uint64_t(q->lplane));
    id = it == fr.pair_map.end() ? int32_t(kDirect) : it->second;
  }
  if (id == kNone) return 0.0;
  if (id < 0) return direct(*p, *q);
  const Table& t = tables_[id];
  if (!t.intervals) return corner_form(t, *p, *q);
  const int32_t* om = t.outer.data();
  const int32_t nq = t.nq_outer;
  const int32_t p0 = p->l[t.p_outer][0] * nq, p1 = p->l[t.p_outer][1] * nq;
  const int32_t q0 = q->l[t.q_outer][0], q1 = q->l[t.q_outer][1];
  const double* v = t.interval_values.data() + 2 * std::size_t(p->r[t.p_inner] * t.nr_q + q->r[t.q_inner]);
  return aligned_rectangles_detail::combine(v + 2 * std::size_t(om[p0 + q0]), v + 2 * std::size_t(om[p0 + q1]),
                                            v + 2 * std::size_t(om[p1 + q0]), v + 2 * std::size_t(om[p1 + q1]));
}

}  // namespace photometria
