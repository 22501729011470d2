// The AVX2 + FMA body of lambert_form_factors() (lambert_batch.h): four source polygons per
// instruction stream, xsimd 8 batches of doubles.
//
// This file alone is compiled with -mavx2 -mfma -ffp-contract=off (top-level CMakeLists.txt) and
// is entered only after lambert_batch.cpp has checked the CPU. It therefore instantiates no
// inline function that other translation units also instantiate — a weak copy compiled for AVX2
// must never be the one the linker keeps for baseline code: it includes only the plain-C part of
// lambert_batch.h (no Eigen) and xsimd, which no other file of the library includes, and whose
// templates carry the architecture in their type. It has no static initializers.
//
// The arithmetic mirrors lambert.cpp operation by operation (same products, same order, no FMA
// contraction), so a_i, the edge normals, their lengths and the dot products are the scalar
// kernel's bit for bit. Only atan2 differs: atan2_upper() below, within 0.65 ulp and equal to
// glibc's in > 99% of cases (tests/test_kernels_batch.cpp).
#define PHOTOMETRIA_LAMBERT_BATCH_INTERNAL_ONLY  // the plain-C part of the header only
#include "kernels/lambert_batch.h"

#if defined(__AVX2__) && defined(__FMA__)

#include <immintrin.h>

#include <cfloat>
#include <cmath>
#include <xsimd/xsimd.hpp>

namespace photometria::lambert_batch_detail {
namespace {

using Arch = xsimd::fma3<xsimd::avx2>;
using B = xsimd::batch<double, Arch>;
using M = xsimd::batch_bool<double, Arch>;
constexpr int kWidth = static_cast<int>(B::size);
static_assert(kWidth == 4 && kPadding % kWidth == 0);

constexpr double kEps = DBL_EPSILON;
constexpr double kTwoPi = 2.0 * M_PI;  // the scalar kernel's divisor, same rounding

struct V3 {
  B x, y, z;
};
inline V3 operator-(const V3& a, const V3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
// Eigen's order for 3-vectors: (x·x' + y·y') + z·z'.
inline B dot(const V3& a, const V3& b) { return (a.x * b.x + a.y * b.y) + a.z * b.z; }
// Eigen's cross product, term for term.
inline V3 cross(const V3& a, const V3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline int bits(const M& m) { return _mm256_movemask_pd(m); }
inline B and_not(const M& m, const B& v) { return B(_mm256_andnot_pd(m, v)); }  // v where m is false, else 0
inline B and_(const M& m, const B& v) { return B(_mm256_and_pd(m, v)); }        // v where m is true, else 0

// Θ = atan2(y, x) for y >= 0, all the kernel needs (y = |a × b|, Θ ∈ [0, π]).
//
// Why not xsimd::atan2: it is good to 2.6 ulps and spends four divisions (y/x, 1/q, the
// reduction (q−1)/(q+1) and a rational approximation, all evaluated for every lane); in this
// sum of nearly cancelling terms 2.6 ulps of Θ use up half of the 1e-16 absolute agreement with
// the scalar kernel (glibc's atan2, 0.52 ulp). This one is within 0.65 ulp, equal to glibc's in
// > 99% of cases, with two divisions, and slightly faster than xsimd's:
//  - octants: lo = min(y, |x|), hi = max(y, |x|), t = lo/hi ∈ [0, 1];
//  - t <= tan(π/8): s = lo/hi, else s = (lo − hi)/(lo + hi) and atan t = π/4 + atan s, formed
//    from (lo, hi) so that one division gives s; |s| <= tan(π/8);
//  - the roundings of the numerator, the denominator and the quotient are recovered exactly
//    (Fast2Sum, FMA residual) and applied to first order: atan(s + ds) ≈ atan s + ds/(1 + s²);
//  - atan s = s − s·z·P(z), z = s², with fdlibm's coefficients (s_atan.c, |s| <= 7/16; Sun
//    Microsystems, freely distributable), evaluated in two interleaved chains as there;
//  - Θ = C + σ·(b + atan s), C ∈ {0, π/2, π}, b ∈ {0, π/4}, σ = ±1, with C + σb and the final
//    sum in Fast2Sum double-double (π/4, π/2, π as hi + lo).
//
// atan2_upper<n> evaluates n independent batches step by step, interleaved: every step is a
// chain of dependent long-latency operations (divisions, square roots, an 11-term polynomial),
// and only independent work next to each other in program order lets the out-of-order core
// overlap them.
template <int n>
inline void atan2_upper(const B* y, const B* x, B* theta) {
  const B sign_bit(-0.0);
  B lo[n], hi[n], num[n], den[n], num_err[n], den_err[n], s[n], ds[n];
  M swap[n], direct[n];
  for (int i = 0; i < n; ++i) {
    const B ax = xsimd::abs(x[i]);
    lo[i] = xsimd::min(y[i], ax), hi[i] = xsimd::max(y[i], ax);
    swap[i] = y[i] > ax;                                  // Θ' = π/2 − Θ
    direct[i] = lo[i] <= B(0.41421356237309503) * hi[i];  // t <= tan(π/8)
    const B hi_or_0 = and_not(direct[i], hi[i]), lo_or_0 = and_not(direct[i], lo[i]);
    num[i] = lo[i] - hi_or_0;
    den[i] = hi[i] + lo_or_0;
    num_err[i] = lo[i] - (num[i] + hi_or_0);  // Fast2Sum(−hi, lo): num + num_err = lo − hi exactly
    den_err[i] = (hi[i] - den[i]) + lo_or_0;  // Fast2Sum(hi, lo)
  }
  for (int i = 0; i < n; ++i) s[i] = num[i] / den[i];
  for (int i = 0; i < n; ++i)  // the true quotient − s, from the exact FMA residual
    ds[i] = xsimd::fnma(s[i], den_err[i], xsimd::fnma(s[i], den[i], num[i]) + num_err[i]) / den[i];
  for (int i = 0; i < n; ++i) {
    const B z = s[i] * s[i], w = z * z;
    const B s1 =
        z *
        xsimd::fma(
            w,
            xsimd::fma(
                w,
                xsimd::fma(w,
                           xsimd::fma(w, xsimd::fma(w, B(1.62858201153657823623e-02), B(4.97687799461593236017e-02)),
                                      B(6.66107313738753120669e-02)),
                           B(9.09088713343650656196e-02)),
                B(1.42857142725034663711e-01)),
            B(3.33333333333329318027e-01));
    const B s2 =
        w * xsimd::fma(
                w,
                xsimd::fma(w,
                           xsimd::fma(w, xsimd::fma(w, B(-3.65315727442169155270e-02), B(-5.83357013379057348645e-02)),
                                      B(-7.69187620504482999495e-02)),
                           B(-1.11111104054623557880e-01)),
                B(-1.99999999998764832476e-01));
    const B tail = xsimd::fnma(s[i], s1 + s2, xsimd::fnma(z, ds[i], ds[i]));  // atan(s + ds) − s
    // C = π/2 (swap), π (x < 0, no swap) or 0; σ = −1 when exactly one of (x < 0, swap).
    const M neg = x[i] < B(0.0);
    const B sigma = B(_mm256_and_pd(_mm256_xor_pd(neg, swap[i]), sign_bit));  // σ's sign bit, applied by xor
    const B b_hi = and_not(direct[i], B(7.85398163397448278999e-01)) ^ sigma;
    const B b_lo = and_not(direct[i], B(3.06161699786838301793e-17)) ^ sigma;
    const B c_hi = xsimd::select(swap[i], B(1.57079632679489655800e+00), and_(neg, B(3.14159265358979311600e+00)));
    const B c_lo = xsimd::select(swap[i], B(6.12323399573676603587e-17), and_(neg, B(1.22464679914735317720e-16)));
    const B k_hi = c_hi + b_hi;
    const B k_lo = ((c_hi - k_hi) + b_hi) + (c_lo + b_lo);  // Fast2Sum: |c_hi| >= |b_hi| or c_hi = 0
    const B ss = s[i] ^ sigma;
    const B t = k_hi + ss;
    const B e = (k_hi - t) + ss;  // Fast2Sum: |k_hi| >= |s| whenever k_hi != 0
    theta[i] = t + (((tail ^ sigma) + k_lo) + e);
  }
}

// Σ_i Θ_i N·(a_i × a_{i+1}) / |a_i × a_{i+1}| over the n edges of polygon a (Heitz 2017 eq. 1,
// Stark 2000 eq. 3; references in lambert.h) — lambert.cpp's edge_angle_sum() term for term (same
// products, same order; a zero-length edge or a receiver on its line adds nothing), the n edges
// interleaved as above. Also Σ_i |term_i|, the scale of the rounding errors of the sum.
template <int n>
inline B lambert_sum(const V3* a, const V3& N, B& abs_sum) {
  B len[n], cos_part[n], normal_part[n], theta[n];
  for (int i = 0; i < n; ++i) {
    const V3& ai = a[i];
    const V3& aj = a[(i + 1) % n];
    // a_i × a_{i+1} = a_i × e = a_{i+1} × e, e = a_{i+1} − a_i: built on the shorter of the two
    // (accurate near the edge's line and near a vertex), exactly as lambert.cpp does.
    const V3 e = aj - ai;
    const M first = dot(ai, ai) <= dot(aj, aj);
    const V3 base{xsimd::select(first, ai.x, aj.x), xsimd::select(first, ai.y, aj.y), xsimd::select(first, ai.z, aj.z)};
    const V3 edge_normal = cross(base, e);
    len[i] = dot(edge_normal, edge_normal);
    cos_part[i] = dot(ai, aj);
    normal_part[i] = dot(N, edge_normal);
  }
  for (int i = 0; i < n; ++i) len[i] = xsimd::sqrt(len[i]);
  atan2_upper<n>(len, cos_part, theta);
  B sum(0.0);
  abs_sum = B(0.0);
  for (int i = 0; i < n; ++i) {
    const B term = xsimd::select(len[i] == B(0.0), B(0.0), (theta[i] * normal_part[i]) / len[i]);
    sum = sum + term;
    abs_sum = abs_sum + xsimd::abs(term);
  }
  return sum;
}

// Polygon k..k+3's edge sum from the chunk's edge terms (shared_edge_terms below), added in the
// order lambert_sum() adds them, and Σ|term|. A triangle's corner 3 repeats corner 2: its edge
// 2 has zero length and adds +0, which leaves the sum as lambert_sum<3>() forms it. (Four scalar
// loads per term: faster here than AVX2's gather, 53 vs 47 M polygons/s in bench_kernels.)
inline B gathered_sum(const View& v, int k, const double* terms, B& abs_sum) {
  B sum(0.0);
  abs_sum = B(0.0);
  for (int c = 0; c < 4; ++c) {
    const int* e = v.edge[c] + k;
    const B term(_mm256_set_pd(terms[e[3]], terms[e[2]], terms[e[1]], terms[e[0]]));
    sum = sum + term;
    abs_sum = abs_sum + xsimd::abs(term);
  }
  return sum;
}

// Lanes k..k+3: the form factors of the "simple" lanes into res (0 elsewhere), and which lanes
// are simple and which are exactly zero (bit l for lane k + l); every other lane needs the
// scalar kernel.
// kEdges = 3 or 4: the polygons' own edges (lambert_sum); 0: their chunk's shared edge terms.
template <int kEdges>
void block(const View& v, int k, double* res, int& simple_bits, int& zero_bits, const double* terms = nullptr) {
  const V3 p{B(v.p[0]), B(v.p[1]), B(v.p[2])};
  const V3 N{B(v.n[0]), B(v.n[1]), B(v.n[2])};

  // Which side of the source's plane p is on, and by how much rounding could blur that: the
  // scalar kernel decides with its own Newell normal of the relative coordinates and the mean
  // height, tolerance 16 ε·magnitude (lambert.cpp). Its and our plane tests differ by at most
  // ~ε·(R + M)(1 + R·shape) times a small constant (R: distance to the farthest corner, bounded
  // by rb; M: magnitude; shape = 2·radius/|Newell|): the Newell vectors of the two kernels are
  // formed from coordinates rounded at the scale of R (relative) and M (absolute), and their
  // directions carry that error divided by the polygon's size; 128 is generous.
  const V3 front{B::load_aligned(v.nx + k), B::load_aligned(v.ny + k), B::load_aligned(v.nz + k)};
  const V3 mean{B::load_aligned(v.ox + k), B::load_aligned(v.oy + k), B::load_aligned(v.oz + k)};
  const V3 d = p - mean;
  const B height = dot(front, d);
  const B magnitude = xsimd::max(B(v.p_magnitude), B::load_aligned(v.magnitude + k));
  const B rb = ((xsimd::abs(d.x) + xsimd::abs(d.y)) + xsimd::abs(d.z)) + B::load_aligned(v.radius + k);
  const B margin =
      B(kEps) * (B(16.0) * magnitude + B(128.0) * (rb + magnitude) * (B(1.0) + rb * B::load_aligned(v.shape + k)));
  // Horizon: N·a_i is computed exactly as the scalar kernel does; the margin is for safety only.
  const B above = B(8.0 * kEps) * rb;

  constexpr int kCorners = kEdges == 0 ? 4 : kEdges;
  V3 a[kCorners];
  B h[kCorners];
  const M valid = B::load_aligned(v.kind + k) > B(0.0);
  M all_above = valid;
  for (int c = 0; c < kCorners; ++c) {
    a[c] = V3{B::load_aligned(v.x[c] + k), B::load_aligned(v.y[c] + k), B::load_aligned(v.z[c] + k)} - p;
    h[c] = dot(N, a[c]);
    all_above = all_above && (h[c] > above);
  }
  M simple = all_above && (height > margin);
  simple_bits = bits(simple);
  zero_bits = 0;
  if (simple_bits != 0xF) {
    // Clearly behind (one-sided), or every vertex clearly below the horizon (the clip leaves
    // nothing, and p cannot be on the boundary): the scalar kernel returns exactly 0 there.
    const B below = -(B(32.0 * kEps) * magnitude + above);
    M all_below = h[0] < below;
    for (int c = 1; c < kCorners; ++c) all_below = all_below && (h[c] < below);
    zero_bits = bits(valid && ((height < -margin) || all_below));
    if (simple_bits == 0) {
      B(0.0).store_aligned(res);
      return;
    }
  }
  B abs_sum;
  B sum;
  if constexpr (kEdges == 0) sum = gathered_sum(v, k, terms, abs_sum);
  else sum = lambert_sum<kEdges>(a, N, abs_sum);
  const B f = (-sum) / B(kTwoPi);
  // The two kernels' atan2s differ by up to ~1.2 ulp of Θ_i, so F differs by up to ~2.6e-16 of
  // Σ|term_i|/(2π). Where the terms cancel so much that this could exceed 1e-16 absolute and
  // 1e-13 relative (with a factor 3 to spare: Σ|term|/(2π) > 1/8 and > 128·|F|; a large polygon
  // seen at grazing incidence from close by), the lane goes to the scalar kernel too.
  const B scale = abs_sum / B(kTwoPi);
  simple = simple && !((scale > B(0.125)) && (scale > B(128.0) * xsimd::abs(f)));
  simple_bits = bits(simple);
  const B clamped = xsimd::select(f < B(0.0), B(0.0), xsimd::select(B(1.0) < f, B(1.0), f));  // std::clamp
  xsimd::select(simple, clamped, B(0.0)).store_aligned(res);
}

// One edge's term Θ N·(a × b)/|a × b|, Θ = atan2(|a × b|, a·b) (Heitz 2017 eq. 1, Stark 2000
// eq. 3), for a polygon that runs it from a to b (ends relative to p): lambert_sum()'s,
// operation for operation, with its cross product on the shorter end
// (a where both are equally far).
struct EdgeParts {
  B len, cos_part, normal_part;
};
inline EdgeParts edge_parts(const V3& a, const V3& b, const V3& N) {
  const V3 e = b - a;
  const M shorter = dot(a, a) <= dot(b, b);
  const V3 base{xsimd::select(shorter, a.x, b.x), xsimd::select(shorter, a.y, b.y), xsimd::select(shorter, a.z, b.z)};
  const V3 edge_normal = cross(base, e);
  return {dot(edge_normal, edge_normal), dot(a, b), dot(N, edge_normal)};
}

// The terms of edges [first, first + 4n) of the view, forwards into terms[0, 4n) and backwards
// into terms[kEdgeStride, kEdgeStride + 4n). Backwards, every product of lambert_sum() changes
// sign exactly (b − a = −(a − b) in IEEE arithmetic, and a · b = b · a), so the term is the
// forward one negated — except where a and b are exactly equally far from p: then the polygon
// that runs the edge backwards builds the cross product on b, and that term is computed too.
template <int n>
void shared_edge_terms(const View& v, int first, const V3& p, const V3& N, double* terms) {
  V3 a[n], b[n];
  B len[n], cos_part[n], normal_part[n], theta[n];
  M tie[n];
  int ties = 0;
  for (int i = 0; i < n; ++i) {
    const int e = first + kWidth * i;
    a[i] = V3{B::load_aligned(v.ex[0] + e), B::load_aligned(v.ey[0] + e), B::load_aligned(v.ez[0] + e)} - p;
    b[i] = V3{B::load_aligned(v.ex[1] + e), B::load_aligned(v.ey[1] + e), B::load_aligned(v.ez[1] + e)} - p;
    const EdgeParts parts = edge_parts(a[i], b[i], N);
    len[i] = parts.len, cos_part[i] = parts.cos_part, normal_part[i] = parts.normal_part;
    tie[i] = dot(a[i], a[i]) == dot(b[i], b[i]);
    ties |= bits(tie[i]);
  }
  for (int i = 0; i < n; ++i) len[i] = xsimd::sqrt(len[i]);
  atan2_upper<n>(len, cos_part, theta);
  for (int i = 0; i < n; ++i) {
    const M zero = len[i] == B(0.0);
    const B term = xsimd::select(zero, B(0.0), (theta[i] * normal_part[i]) / len[i]);
    term.store_aligned(terms + kWidth * i);
    xsimd::select(zero, B(0.0), -term).store_aligned(terms + kEdgeStride + kWidth * i);
  }
  if (ties == 0) return;
  for (int i = 0; i < n; ++i) {  // the backwards terms of the tied lanes, from b to a
    if (bits(tie[i]) == 0) continue;
    const EdgeParts parts = edge_parts(b[i], a[i], N);
    const B length = xsimd::sqrt(parts.len);
    B angle;
    atan2_upper<1>(&length, &parts.cos_part, &angle);
    const B term = xsimd::select(length == B(0.0), B(0.0), (angle * parts.normal_part) / length);
    double* out = terms + kEdgeStride + kWidth * i;
    xsimd::select(tie[i], term, B::load_aligned(out)).store_aligned(out);
  }
}

}  // namespace

bool avx2_compiled() { return true; }

int lambert_avx2(const View& v, int begin, int end, double* out, int* scalar_lanes) {
  int fallbacks = 0;
  // A whole chunk with shared edges: its edges' terms once, then each polygon's sum from them.
  alignas(32) double terms[2 * kEdgeStride];  // forwards, then backwards
  const int chunk = begin / kEdgeChunk;
  const int chunk_end = begin + kEdgeChunk < v.size ? begin + kEdgeChunk : v.size;  // (no <algorithm> here)
  const bool shared = v.chunk_edges && begin % kEdgeChunk == 0 && end == chunk_end &&
                      v.chunk_edges[chunk + 1] - v.chunk_edges[chunk] <= kEdgeStride;
  if (shared) {
    const V3 p{B(v.p[0]), B(v.p[1]), B(v.p[2])};
    const V3 N{B(v.n[0]), B(v.n[1]), B(v.n[2])};
    const int first = v.chunk_edges[chunk], last = v.chunk_edges[chunk + 1];
    int e = first;
    for (; e + 4 * kWidth <= last; e += 4 * kWidth) shared_edge_terms<4>(v, e, p, N, terms + (e - first));
    for (; e < last; e += kWidth) shared_edge_terms<1>(v, e, p, N, terms + (e - first));
  }
  for (int k = begin - begin % kWidth; k < end; k += kWidth) {
    alignas(32) double res[kWidth];
    int simple = 0, zero = 0;
    // A block of triangles only needs three edges.
    if (shared) block<0>(v, k, res, simple, zero, terms);
    else if (xsimd::all(B::load_aligned(v.kind + k) == B(3.0))) block<3>(v, k, res, simple, zero);
    else block<4>(v, k, res, simple, zero);
    if (simple == 0xF && k >= begin && k + kWidth <= end) {
      B::load_aligned(res).store_unaligned(out + (k - begin));
      continue;
    }
    for (int l = 0; l < kWidth; ++l) {
      const int kk = k + l;
      if (kk < begin || kk >= end) continue;
      out[kk - begin] = res[l];
      if (!((simple | zero) >> l & 1)) scalar_lanes[fallbacks++] = kk;
    }
  }
  return fallbacks;
}

bool simd_atan2_avx2(const double* y, const double* x, double* out, int n) {
  for (int i = 0; i < n; i += kWidth) {
    alignas(32) double yy[kWidth] = {0, 0, 0, 0}, xx[kWidth] = {1, 1, 1, 1}, r[kWidth];
    for (int l = 0; l < kWidth && i + l < n; ++l) yy[l] = y[i + l], xx[l] = x[i + l];
    const B yb = B::load_aligned(yy), xb = B::load_aligned(xx);
    B t;
    atan2_upper<1>(&yb, &xb, &t);
    t.store_aligned(r);
    for (int l = 0; l < kWidth && i + l < n; ++l) out[i + l] = r[l];
  }
  return true;
}

// Θ·proj/len with Θ = atan2(len, dot), len = √len2, as the scalar kernel rounds it: (Θ·proj)/len;
// 0 where len2 = 0 (Heitz 2017 eq. 1, one edge's term).
inline B edge_term(const B& len2, const B& ab, const B& proj) {
  const B len = xsimd::sqrt(len2);
  B theta;
  atan2_upper<1>(&len, &ab, &theta);
  const M zero = len2 == B(0.0);
  return and_not(zero, (theta * proj) / xsimd::select(zero, B(1.0), len));
}

void edge_terms_avx2(const double* len2, const double* dot, const double* proj, double* out, int n) {
  for (int i = 0; i < n; i += kWidth) {
    alignas(32) double ll[kWidth] = {0, 0, 0, 0}, dd[kWidth] = {1, 1, 1, 1}, pp[kWidth] = {0, 0, 0, 0}, r[kWidth];
    for (int l = 0; l < kWidth && i + l < n; ++l) ll[l] = len2[i + l], dd[l] = dot[i + l], pp[l] = proj[i + l];
    edge_term(B::load_aligned(ll), B::load_aligned(dd), B::load_aligned(pp)).store_aligned(r);
    for (int l = 0; l < kWidth && i + l < n; ++l) out[i + l] = r[l];
  }
}

double small_polygon_edge_sum_avx2(const double* x, const double* y, const double* z, int n, const double* N) {
  // Lane k holds edge k: a = a_k, b = a_{k+1} (lanes rotated by one; for a triangle lane 3 is unused).
  const V3 a{B::load_unaligned(x), B::load_unaligned(y), B::load_unaligned(z)};
  const auto next = [n](const B& v) {
    return B(n == 4 ? _mm256_permute4x64_pd(v, 0x39) : _mm256_permute4x64_pd(v, 0x09));  // (1,2,3,0) / (1,2,0,0)
  };
  const V3 b{next(a.x), next(a.y), next(a.z)};
  const V3 e = b - a;
  const M a_shorter = dot(a, a) <= dot(b, b);
  const V3 s{xsimd::select(a_shorter, a.x, b.x), xsimd::select(a_shorter, a.y, b.y),
             xsimd::select(a_shorter, a.z, b.z)};
  const V3 c = cross(s, e);  // a_k × a_{k+1}, on the shorter of the two (lambert.cpp)
  const V3 normal{B(N[0]), B(N[1]), B(N[2])};
  const B term = edge_term(dot(c, c), dot(a, b), dot(normal, c));
  alignas(32) double t[kWidth];
  term.store_aligned(t);
  double sum = 0.0;
  for (int k = 0; k < n; ++k) sum += t[k];  // in order, as the scalar kernel
  return sum;
}

bool xsimd_atan2_avx2(const double* y, const double* x, double* out, int n) {
  for (int i = 0; i < n; i += kWidth) {
    alignas(32) double yy[kWidth] = {0, 0, 0, 0}, xx[kWidth] = {1, 1, 1, 1}, r[kWidth];
    for (int l = 0; l < kWidth && i + l < n; ++l) yy[l] = y[i + l], xx[l] = x[i + l];
    xsimd::atan2(B::load_aligned(yy), B::load_aligned(xx)).store_aligned(r);
    for (int l = 0; l < kWidth && i + l < n; ++l) out[i + l] = r[l];
  }
  return true;
}

}  // namespace photometria::lambert_batch_detail

#else  // no AVX2 at compile time (not x86-64): lambert_batch.cpp uses the scalar kernel

namespace photometria::lambert_batch_detail {
bool avx2_compiled() { return false; }
int lambert_avx2(const View&, int, int, double*, int*) { return 0; }
bool simd_atan2_avx2(const double*, const double*, double*, int) { return false; }
void edge_terms_avx2(const double*, const double*, const double*, double*, int) {}
double small_polygon_edge_sum_avx2(const double*, const double*, const double*, int, const double*) { return 0.0; }
bool xsimd_atan2_avx2(const double*, const double*, double*, int) { return false; }
}  // namespace photometria::lambert_batch_detail

#endif
