#include "kernels/stark.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "kernels/visible_polygon.h"

namespace photometria {
namespace {

thread_local VisiblePolygon scratch;

// ∠(a, e) N·n̂ with n̂ = (a × e)/|a × e|, 0 when a × e = 0 (seed 002 eqs. 11–13).
double vertex_edge_term(const Vec3& a, const Vec3& e, const Vec3& N) {
  const Vec3 axe = a.cross(e);
  const double s = axe.norm();
  if (s == 0.0) return 0.0;
  return std::atan2(s, a.dot(e)) * N.dot(axe) / s;
}

// End term of an edge at vertex a in homogeneous image-plane coordinates (seed 002 eq. 45,
// Fig. 11): with the vertex as the homogeneous point (X, Y, W) = (u·a, w·a, N·a) and the edge as
// its homogeneous line l ∝ a_i × a_{i+1} (unit edge normal n̂),
//   C (a y − b x) = −N·n̂,   C (a x + b y) = N·(a × n̂) / W,
// so G = −(N·n̂) atan2(N·(a × n̂), W). For a vertex on the receiver plane (W = 0, a vertex at
// infinity) atan2 gives the ±π/2 of Fig. 11's "vertex at infinity" row without a special case.
double G(const Vec3& a, double W, const Vec3& n_hat, const Vec3& N) {
  return -N.dot(n_hat) * std::atan2(N.dot(a.cross(n_hat)), W);
}

// End term of an edge at infinity (both ends on the receiver plane), measured from the edge
// vector d (seed 002 eq. 46, Fig. 11 last row): atan((d·Q) / (N·(d × Q))).
double H(const Vec3& q, const Vec3& d, const Vec3& N) { return std::atan(d.dot(q) / N.dot(d.cross(q))); }

}  // namespace

double stark_vertex_form_factor(const Receiver& receiver, const Vec3* v, int n) {
  if (!visible_polygon(receiver, v, n, scratch)) return 0.0;
  const Polygon& a = scratch.a;
  const Vec3& N = receiver.normal;
  const size_t m = a.size();
  double sum = 0.0;
  for (size_t i = 0; i < m; ++i) {
    const Vec3& ai = a[i];
    const Vec3 e_in = ai - a[(i + m - 1) % m];
    const Vec3 e_out = a[(i + 1) % m] - ai;
    sum += vertex_edge_term(ai, e_in, N) - vertex_edge_term(ai, e_out, N);  // eq. (12)
  }
  return std::clamp(sum / (2.0 * M_PI), 0.0, 1.0);
}

double stark_image_form_factor(const Receiver& receiver, const Vec3* v, int n) {
  if (!visible_polygon(receiver, v, n, scratch)) return 0.0;
  const Polygon& a = scratch.a;
  const Vec3& N = receiver.normal;
  const size_t m = a.size();
  constexpr double kEps = std::numeric_limits<double>::epsilon();
  thread_local std::vector<double> W;
  W.resize(m);
  for (size_t i = 0; i < m; ++i) {
    W[i] = N.dot(a[i]);  // homogeneous coordinate: the height above the receiver plane (eq. 4)
    // On the receiver plane up to the rounding of the clip: a point at infinity (sec. 6.4).
    if (W[i] <= 8.0 * kEps * a[i].norm()) W[i] = 0.0;
  }
  // Σ over edges of [end term − start term] = Σ over vertices of [incoming − outgoing] (eq. 44).
  double sum = 0.0;
  for (size_t i = 0; i < m; ++i) {
    const size_t j = (i + 1) % m;
    const Vec3 d = a[j] - a[i];
    if (W[i] == 0.0 && W[j] == 0.0) {  // edge at infinity: eq. (46)
      const double denom = N.dot(d.cross(a[i]));
      if (denom == 0.0) continue;  // along a line through p: no angle swept
      sum += H(a[j], d, N) - H(a[i], d, N);
      continue;
    }
    const Vec3 line = a[i].cross(d);  // homogeneous line through both vertices
    const double len = line.norm();
    if (len == 0.0) continue;  // zero-length edge, or edge along a view ray
    const Vec3 n_hat = line / len;
    sum += G(a[j], W[j], n_hat, N) - G(a[i], W[i], n_hat, N);
  }
  return std::clamp(sum / (2.0 * M_PI), 0.0, 1.0);
}

}  // namespace photometria
