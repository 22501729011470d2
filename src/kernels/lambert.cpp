#include "kernels/lambert.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "kernels/lambert_batch.h"
#include "kernels/visible_polygon.h"

namespace photometria {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();

// Per-thread scratch: patches have 3–4 vertices; clipping and boundary vertices can at most
// double that. Larger query polygons fall back to the heap.
thread_local VisiblePolygon scratch;
thread_local Polygon boundary_scratch;

}  // namespace

bool visible_polygon(const Receiver& receiver, const Vec3* v, int n, VisiblePolygon& out) {
  out.whole = false;
  if (n < 3) return false;
  const Vec3& p = receiver.point;
  const Vec3& N = receiver.normal;
  Polygon& a = out.a;
  a.resize(n);
  double magnitude = p.lpNorm<Eigen::Infinity>();
  bool all_above = true;
  for (int i = 0; i < n; ++i) {
    a[i] = v[i] - p;  // relative to the receiver: a 1e6 offset of everything changes nothing
    magnitude = std::max(magnitude, v[i].lpNorm<Eigen::Infinity>());
    all_above = all_above && N.dot(a[i]) >= 0.0;
  }
  const Vec3 newell = newell_vector(a);
  const double newell_len = newell.norm();
  if (newell_len == 0.0 || magnitude == 0.0) return false;  // degenerate polygon
  const Vec3 front = newell / newell_len;
  // Signed distance of p in front of the polygon's plane (mean over vertices for robustness).
  Vec3 mean = Vec3::Zero();
  for (const Vec3& ai : a) mean += ai;
  const double height = -front.dot(mean) / n;
  // What rounding of the inputs can hide: a few ulps of the coordinates' magnitude.
  const double tol = 16.0 * kEps * magnitude;
  if (height < -tol) return false;  // seen from the back: one-sided

  if (height <= tol) {
    // p lies in the polygon's plane: zero solid angle unless p is on the boundary, where the
    // value is the limit as p is approached from inside the receiver's surface.
    Polygon& boundary = boundary_scratch;
    boundary.clear();
    bool on_boundary = false;
    for (int i = 0; i < n; ++i) {
      const Vec3& ai = a[i];
      const Vec3& aj = a[(i + 1) % n];
      const bool at_vertex = ai.norm() <= tol;
      if (at_vertex) {
        on_boundary = true;
        boundary.push_back(Vec3::Zero());
        continue;
      }
      boundary.push_back(ai);
      const Vec3 e = aj - ai;
      if (aj.norm() > tol && ai.cross(e).norm() <= tol * e.norm() && ai.dot(aj) < 0) {
        on_boundary = true;  // p strictly inside edge i: split the edge at p
        boundary.push_back(Vec3::Zero());
      }
    }
    if (!on_boundary) return false;
    Vec3 u = receiver.approach.isZero() ? Vec3(front - front.dot(N) * N) : receiver.approach;
    u -= u.dot(N) * N;  // keep the approach in the receiver plane
    const double ulen = u.norm();
    if (ulen <= 1e-12 || front.dot(u) <= 0.0) return false;  // polygon in the receiver plane, or approached from behind
    u /= ulen;
    // Seen from p + εu, a vertex at p lies in direction -u (only directions matter below).
    for (Vec3& b : boundary)
      if (b.isZero()) b = -u;
    a.swap(boundary);
    all_above = false;  // clip below: the substituted directions lie on the horizon
  }

  if (all_above) {
    out.whole = true;  // wholly above the horizon: no clipping needed
    return true;
  }
  boundary_scratch.swap(a);
  clip_to_halfspace(boundary_scratch.data(), static_cast<int>(boundary_scratch.size()), N, a);
  return a.size() >= 3;
}

namespace {

// Σ_i Θ_i N·(a_i × a_{i+1}) / |a_i × a_{i+1}| over the m edges starting at `first` of the closed
// polygon a[0..n) (see edge_angle_sum); m <= 16.
double edge_angle_block(const Vec3* a, size_t n, size_t first, size_t m, const Vec3& N) {
  double len2[16], dot[16], proj[16];
  for (size_t k = 0; k < m; ++k) {
    const size_t i = first + k;
    const Vec3& ai = a[i];
    const Vec3& aj = a[i + 1 == n ? 0 : i + 1];
    // a_i × a_{i+1} = a_i × e = a_{i+1} × e (e = a_{i+1} − a_i), built on the shorter of the
    // two: accurate when p is near the edge's line and when it is near a vertex.
    const Vec3 e = aj - ai;
    const Vec3 edge_normal = (ai.squaredNorm() <= aj.squaredNorm() ? ai : aj).cross(e);
    len2[k] = edge_normal.squaredNorm();
    dot[k] = ai.dot(aj);
    proj[k] = N.dot(edge_normal);
  }
  // Θ_i = atan2(|a_i × a_{i+1}|, a_i · a_{i+1}); len 0 (zero-length edge or p on its line) adds nothing
  return edge_term_sum(len2, dot, proj, static_cast<int>(m));
}

}  // namespace

bool whole_polygon_edge_sum(const Receiver& receiver, const Vec3* v, int n, double& sum, double far_factor) {
  if (n < 3 || n > kWholeMaxVertices) return false;
  const Vec3& p = receiver.point;
  const Vec3& N = receiver.normal;
  Vec3 a[kWholeMaxVertices];
  // a as structure of arrays too, for small_polygon_edge_sum(), written early (a vector load
  // right after the scalar stores would stall on store forwarding).
  alignas(32) double x[4], y[4], z[4];
  double magnitude = p.lpNorm<Eigen::Infinity>();
  Vec3 mean = Vec3::Zero();
  for (int i = 0; i < n; ++i) {
    a[i] = v[i] - p;  // relative to the receiver, as visible_polygon()
    if (i < 4) x[i] = a[i].x(), y[i] = a[i].y(), z[i] = a[i].z();
    if (N.dot(a[i]) < 0.0) return false;  // below the horizon: clipping needed
    magnitude = std::max(magnitude, v[i].lpNorm<Eigen::Infinity>());
    mean += a[i];
  }
  Vec3 newell = Vec3::Zero();  // newell_vector(a, n) (geometry/polygon.cpp), inlined here
  for (int i = 1; i + 1 < n; ++i) newell += (a[i] - a[0]).cross(a[i + 1] - a[0]);
  if (newell.squaredNorm() == 0.0 || magnitude == 0.0) return false;  // degenerate: the general path says 0
  if (far_factor > 0.0) {
    double rmax2 = 0.0;
    for (int i = 1; i < n; ++i) rmax2 = std::max(rmax2, (v[i] - v[0]).squaredNorm());
    if (far_factor * rmax2 <= a[0].squaredNorm()) return false;  // far: the caller's own form
  }
  // visible_polygon()'s tests on height = −front·mean/n against tol, front = newell/|newell|,
  // squared to spare a square root and a division: h = −newell·mean is height·n·|newell|.
  const double h = -newell.dot(mean);
  const double tol = 16.0 * kEps * magnitude;
  const double bound2 = (tol * n) * (tol * n) * newell.squaredNorm();
  if (h < 0.0 && h * h > bound2) {
    sum = 0.0;  // seen from the back: one-sided
    return true;
  }
  if (h <= 0.0 || h * h <= bound2) return false;  // in the polygon's plane: boundary limits
  if (n <= 4) {
    if (n == 3) x[3] = x[0], y[3] = y[0], z[3] = z[0];  // unused lane, kept finite
    if (small_polygon_edge_sum(x, y, z, n, N.data(), sum)) return true;
  }
  sum = edge_angle_block(a, static_cast<size_t>(n), 0, static_cast<size_t>(n), N);
  return true;
}

double edge_angle_sum(const Polygon& a, const Vec3& N) {
  // Heitz 2017 eq. (1), Stark 2000 eq. (3) (lambert.h); see visible_polygon.h
  constexpr size_t kBlock = 16;  // patches and clipped patches have at most 8 vertices
  const size_t n = a.size();
  double sum = 0.0;
  for (size_t start = 0; start < n; start += kBlock)
    sum += edge_angle_block(a.data(), n, start, std::min(kBlock, n - start), N);
  return sum;
}

double lambert_form_factor(const Receiver& receiver, const Vec3* v, int n) {
  double sum;
  if (whole_polygon_edge_sum(receiver, v, n, sum)) return std::clamp(-sum / (2.0 * M_PI), 0.0, 1.0);
  if (!visible_polygon(receiver, v, n, scratch)) return 0.0;
  const double f = -edge_angle_sum(scratch.a, receiver.normal) / (2.0 * M_PI);
  return std::clamp(f, 0.0, 1.0);
}

}  // namespace photometria
