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

double edge_angle_sum(const Polygon& a, const Vec3& N) {
  // seed 000 eq. (1), seed 002 eq. (3); see visible_polygon.h
  constexpr size_t kMax = 16;  // patches and clipped patches have at most 8 vertices
  const size_t n = a.size();
  double len[kMax], dot[kMax], proj[kMax], theta[kMax];
  double sum = 0.0;
  for (size_t start = 0; start < n; start += kMax) {
    const size_t m = std::min(kMax, n - start);
    for (size_t k = 0; k < m; ++k) {
      const size_t i = start + k;
      const Vec3& ai = a[i];
      const Vec3& aj = a[(i + 1) % n];
      // a_i × a_{i+1} = a_i × e = a_{i+1} × e (e = a_{i+1} − a_i), built on the shorter of the
      // two: accurate when p is near the edge's line and when it is near a vertex.
      const Vec3 e = aj - ai;
      const Vec3 edge_normal = (ai.squaredNorm() <= aj.squaredNorm() ? ai : aj).cross(e);
      len[k] = edge_normal.norm();
      dot[k] = ai.dot(aj);
      proj[k] = N.dot(edge_normal);
    }
    edge_angles(len, dot, theta, static_cast<int>(m));  // Θ_i = atan2(|a_i × a_{i+1}|, a_i · a_{i+1})
    for (size_t k = 0; k < m; ++k)
      if (len[k] != 0.0) sum += theta[k] * proj[k] / len[k];  // len 0: zero-length edge or p on its line
  }
  return sum;
}

double lambert_form_factor(const Receiver& receiver, const Vec3* v, int n) {
  if (!visible_polygon(receiver, v, n, scratch)) return 0.0;
  const double f = -edge_angle_sum(scratch.a, receiver.normal) / (2.0 * M_PI);
  return std::clamp(f, 0.0, 1.0);
}

}  // namespace photometria
