// PolygonBatch and the dispatch of lambert_form_factors() (lambert_batch.h): the AVX2 kernel
// (lambert_batch_avx2.cpp) when the CPU has it, the scalar lambert_form_factor() for the lanes
// it leaves, and for everything on a CPU without AVX2. Compiled for baseline x86-64.
#include "kernels/lambert_batch.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>

namespace photometria {
static_assert(PolygonBatch::kPadding == lambert_batch_detail::kPadding);
static_assert(PolygonBatch::kEdgeChunk == lambert_batch_detail::kEdgeChunk);
static_assert(PolygonBatch::kEdgeStride == lambert_batch_detail::kEdgeStride);
static_assert(PolygonBatch::kEdgeChunk % PolygonBatch::kPadding == 0);
namespace {

std::atomic<bool> simd_enabled{true};

// AVX2 and FMA usable: the CPU has them and the OS saves the YMM registers (GCC's and Clang's
// __builtin_cpu_supports check XCR0 too; xsimd 8.1's available_architectures() does not).
bool cpu_has_avx2_fma() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#else
  return false;
#endif
}

bool use_avx2() {
  static const bool ok = lambert_batch_detail::avx2_compiled() && cpu_has_avx2_fma();
  return ok && simd_enabled.load(std::memory_order_relaxed);
}

double inf_norm(const Vec3& v) { return v.lpNorm<Eigen::Infinity>(); }

}  // namespace

PolygonBatch::PolygonBatch(const std::vector<Polygon>& polygons) {
  reserve(static_cast<int>(polygons.size()));
  for (const Polygon& p : polygons) push_back(p);
}

void PolygonBatch::reserve(int polygons) {
  const size_t n = static_cast<size_t>((std::max(polygons, 0) + kPadding - 1) / kPadding * kPadding);
  for (int c = 0; c < 4; ++c) x[c].reserve(n), y[c].reserve(n), z[c].reserve(n);
  vertex_count.reserve(n);
  for (AlignedDoubles* a : {&kind, &nx, &ny, &nz, &ox, &oy, &oz, &magnitude, &radius, &shape}) a->reserve(n);
}

void PolygonBatch::push_back(const Vec3* v, int n) {
  if (n < 0 || n > 4)
    throw std::invalid_argument("PolygonBatch: a polygon has " + std::to_string(n) +
                                " vertices; at most 4 are supported (triangulate first)");
  if (size == padded) {  // grow by one padding block of zeros (kind 0: never evaluated)
    padded += kPadding;
    const size_t m = static_cast<size_t>(padded);
    for (int c = 0; c < 4; ++c) x[c].resize(m, 0.0), y[c].resize(m, 0.0), z[c].resize(m, 0.0);
    vertex_count.resize(m, 0);
    for (AlignedDoubles* a : {&kind, &nx, &ny, &nz, &ox, &oy, &oz, &magnitude, &radius, &shape}) a->resize(m, 0.0);
  }
  chunk_edges.clear();  // share_edges() again after the last polygon
  const int k = size++;
  vertex_count[k] = n;
  for (int c = 0; c < 4; ++c) {
    // Triangles repeat their last corner; fewer than 3 vertices are kept as given (F = 0).
    const Vec3 corner = n == 0 ? Vec3::Zero() : v[std::min(c, n - 1)];
    x[c][k] = corner.x(), y[c][k] = corner.y(), z[c][k] = corner.z();
  }
  kind[k] = 0.0;
  if (n < 3) return;

  // Plane, size and distance bounds for the rounding margins (see lambert_batch_avx2.cpp).
  const Vec3 newell = newell_vector(v, n);  // relative to v_0: keeps digits far from the origin
  const double newell_len = newell.norm();
  Vec3 mean = Vec3::Zero();
  double mag = 0.0;
  for (int i = 0; i < n; ++i) mean += v[i], mag = std::max(mag, inf_norm(v[i]));
  mean /= n;
  double rad = 0.0;
  for (int i = 0; i < n; ++i) rad = std::max(rad, (v[i] - mean).norm());
  const Vec3 front = newell / newell_len;
  const double shp = 2.0 * rad / newell_len;
  nx[k] = front.x(), ny[k] = front.y(), nz[k] = front.z();
  ox[k] = mean.x(), oy[k] = mean.y(), oz[k] = mean.z();
  magnitude[k] = mag, radius[k] = rad, shape[k] = shp;
  // Degenerate, or non-finite anywhere (coordinates, or bounds that overflowed): scalar path.
  const bool finite = std::isfinite(newell_len) && front.allFinite() && mean.allFinite() && std::isfinite(mag) &&
                      std::isfinite(rad) && std::isfinite(shp);
  if (newell_len > 0.0 && finite) kind[k] = n;
}

int PolygonBatch::vertices(int k, Vec3 v[4]) const {
  const int n = vertex_count[k];
  for (int c = 0; c < n; ++c) v[c] = Vec3(x[c][k], y[c][k], z[c][k]);
  return n;
}

void PolygonBatch::share_edges() {
  const size_t m = static_cast<size_t>(padded);
  for (int c = 0; c < 4; ++c) edge[c].assign(m, 0);
  for (int i = 0; i < 2; ++i) ex[i].clear(), ey[i].clear(), ez[i].clear();
  chunk_edges.assign(1, 0);
  using Point = std::array<double, 3>;
  std::map<std::pair<Point, Point>, int> found;  // a chunk's edges by their ends in increasing order
  auto add_edge = [&](const Point& from, const Point& to) {
    for (int i = 0; i < 2; ++i) {
      const Point& q = i == 0 ? from : to;
      ex[i].push_back(q[0]), ey[i].push_back(q[1]), ez[i].push_back(q[2]);
    }
    return static_cast<int>(ex[0].size()) - chunk_edges.back() - 1;
  };
  for (int first = 0; first < padded; first += kEdgeChunk) {
    found.clear();
    for (int k = first; k < std::min(padded, first + kEdgeChunk); ++k)
      for (int c = 0; c < 4; ++c) {
        const int d = (c + 1) % 4;
        const Point from{x[c][k], y[c][k], z[c][k]}, to{x[d][k], y[d][k], z[d][k]};
        if (kind[k] == 0.0) {  // padding, degenerate or non-finite: an edge of its own (no NaN as a key)
          edge[c][k] = add_edge(from, to);
          continue;
        }
        const bool forward = !(to < from);
        auto [it, inserted] = found.try_emplace(forward ? std::pair(from, to) : std::pair(to, from), 0);
        if (inserted) it->second = add_edge(it->first.first, it->first.second);
        edge[c][k] = it->second + (forward ? 0 : kEdgeStride);
      }
    while ((ex[0].size() - size_t(chunk_edges.back())) % 4 != 0) add_edge({0, 0, 0}, {0, 0, 0});  // zero terms
    chunk_edges.push_back(static_cast<int>(ex[0].size()));
  }
}

int lambert_form_factors(const Receiver& receiver, const PolygonBatch& sources, int begin, int end, double* out) {
  if (begin < 0 || end > sources.size || begin > end)
    throw std::out_of_range("lambert_form_factors: range [" + std::to_string(begin) + ", " + std::to_string(end) +
                            ") outside the batch of " + std::to_string(sources.size));
  Vec3 v[4];
  if (!use_avx2()) {
    for (int k = begin; k < end; ++k) out[k - begin] = lambert_form_factor(receiver, v, sources.vertices(k, v));
    return end - begin;
  }
  lambert_batch_detail::View view{};
  for (int c = 0; c < 4; ++c)
    view.x[c] = sources.x[c].data(), view.y[c] = sources.y[c].data(), view.z[c] = sources.z[c].data();
  view.kind = sources.kind.data();
  view.nx = sources.nx.data(), view.ny = sources.ny.data(), view.nz = sources.nz.data();
  view.ox = sources.ox.data(), view.oy = sources.oy.data(), view.oz = sources.oz.data();
  view.magnitude = sources.magnitude.data(), view.radius = sources.radius.data(), view.shape = sources.shape.data();
  for (int i = 0; i < 3; ++i) view.p[i] = receiver.point[i], view.n[i] = receiver.normal[i];
  view.p_magnitude = inf_norm(receiver.point);
  view.size = sources.size;
  if (sources.edges_shared()) {
    for (int i = 0; i < 2; ++i)
      view.ex[i] = sources.ex[i].data(), view.ey[i] = sources.ey[i].data(), view.ez[i] = sources.ez[i].data();
    view.chunk_edges = sources.chunk_edges.data();
    for (int c = 0; c < 4; ++c) view.edge[c] = sources.edge[c].data();
  }

  // In chunks, so that the list of lanes left to the scalar kernel stays on the stack; chunk
  // boundaries are multiples of the SIMD width, so no block is evaluated twice, and are those of
  // the shared edges.
  constexpr int kChunk = PolygonBatch::kEdgeChunk;
  int scalar_lanes[kChunk];
  int scalar_calls = 0;
  for (int b = begin, e; b < end; b = e) {
    e = std::min(end, b - b % kChunk + kChunk);
    const int fallbacks = lambert_batch_detail::lambert_avx2(view, b, e, out + (b - begin), scalar_lanes);
    for (int i = 0; i < fallbacks; ++i) {
      const int k = scalar_lanes[i];
      const int nv = sources.vertices(k, v);
      // A polygon lying exactly in the receiver's plane (every N·(v_i − p) exactly 0: the
      // neighbours of a vertex on its own wall) subtends no solid angle; the scalar kernel's
      // in-plane branch returns 0 for it too (also on its boundary, where the approach
      // direction lies in that plane). Common in rectilinear rooms, so not worth a scalar call.
      bool in_plane = nv >= 3;
      for (int c = 0; c < nv && in_plane; ++c) in_plane = receiver.normal.dot(v[c] - receiver.point) == 0.0;
      if (in_plane) {
        out[k - begin] = 0.0;
        continue;
      }
      out[k - begin] = lambert_form_factor(receiver, v, nv);
      ++scalar_calls;
    }
  }
  return scalar_calls;
}

double edge_term_sum(const double* len2, const double* dot, const double* proj, int n) {
  double sum = 0.0;
  if (use_avx2()) {
    constexpr int kBlock = 16;
    double term[kBlock];
    for (int start = 0; start < n; start += kBlock) {
      const int m = std::min(kBlock, n - start);
      lambert_batch_detail::edge_terms_avx2(len2 + start, dot + start, proj + start, term, m);
      for (int k = 0; k < m; ++k) sum += term[k];
    }
    return sum;
  }
  for (int k = 0; k < n; ++k) {
    if (len2[k] == 0.0) continue;
    const double len = std::sqrt(len2[k]);
    sum += std::atan2(len, dot[k]) * proj[k] / len;
  }
  return sum;
}

bool small_polygon_edge_sum(const double* x, const double* y, const double* z, int n, const double* N, double& sum) {
  if ((n != 3 && n != 4) || !use_avx2()) return false;
  sum = lambert_batch_detail::small_polygon_edge_sum_avx2(x, y, z, n, N);
  return true;
}

const char* lambert_batch_isa() { return use_avx2() ? "avx2" : "scalar"; }

namespace lambert_batch_detail {
void set_simd_enabled(bool enabled) { simd_enabled.store(enabled, std::memory_order_relaxed); }
bool simd_atan2(const double* y, const double* x, double* out, int n) {
  return use_avx2() && simd_atan2_avx2(y, x, out, n);
}
bool xsimd_atan2(const double* y, const double* x, double* out, int n) {
  return use_avx2() && xsimd_atan2_avx2(y, x, out, n);
}
}  // namespace lambert_batch_detail

}  // namespace photometria
