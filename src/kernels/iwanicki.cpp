#include "kernels/iwanicki.h"

#include <algorithm>
#include <cmath>

#include "kernels/lambert_batch.h"
#include "kernels/visible_polygon.h"

namespace photometria {
namespace {

thread_local VisiblePolygon scratch;

// The centred sum applies when every vertex is within |c|/16 of c = v_0 − p: 16² = 256.
constexpr double kCentredFactor = 256.0;
thread_local Polygon relative;

// atan(t)/t − 1 = −t²/3 + t⁴/5 − t⁶/7 + …  for 0 <= t < 0.2 (12 terms: error < 1e-17 relative).
double atan_ratio_minus_one(double t) {
  const double t2 = t * t;
  double s = 0.0;
  for (int k = 12; k >= 1; --k) s = t2 * ((k % 2 == 0 ? 1.0 : -1.0) / (2 * k + 1) + s);
  return s;
}

// Σ_i (Ω_i / |a_i × a_{i+1}|) (a_i × a_{i+1})·N (Iwanicki, final formula; the direct form is
// edge_angle_sum() of visible_polygon.h), rearranged around c = a_0 with Σ e_i = 0 (see
// iwanicki.h). Requires small angles (every |r_i| <= |c|/16), so that a_i·a_{i+1} > 0 and
// t_i = tan Ω_i < 0.2.
double centered_sum(const Vec3& c, const Polygon& r, const Vec3& N) {
  const double cc = c.squaredNorm();
  const size_t n = r.size();
  Vec3 s1 = Vec3::Zero();  // Σ (w_i − w̄) e_i
  Vec3 s2 = Vec3::Zero();  // Σ w_i r_i × e_i
  for (size_t i = 0; i < n; ++i) {
    const Vec3& ri = r[i];
    const Vec3& rj = r[(i + 1) % n];
    const Vec3 e = rj - ri;
    const Vec3 rxe = ri.cross(e);
    const Vec3 cross = c.cross(e) + rxe;  // a_i × a_{i+1}
    const double s = cross.norm();
    const double delta = c.dot(ri + rj) + ri.dot(rj);  // a_i·a_{i+1} − |c|², no cancellation
    const double dot = cc + delta;                     // a_i·a_{i+1} > 0 here
    double w = 1.0 / cc, dw = 0.0;                     // any weight serves when a_i × a_{i+1} = 0
    if (s != 0.0) {
      const double g1 = atan_ratio_minus_one(s / dot);  // Ω/tan Ω − 1
      w = (1.0 + g1) / dot;                             // Ω_i / |a_i × a_{i+1}|
      dw = g1 / dot - delta / (dot * cc);               // w_i − 1/|c|²
    }
    s1 += dw * e;
    s2 += w * rxe;
  }
  return N.dot(c.cross(s1) + s2);
}

}  // namespace

double iwanicki_form_factor(const Receiver& receiver, const Vec3* v, int n) {
  // Near polygons (the centred form below does not apply) that need no clipping: the direct
  // form in one pass on the stack, as the general path below would compute it.
  double sum;
  if (whole_polygon_edge_sum(receiver, v, n, sum, kCentredFactor)) return std::clamp(-sum / (2.0 * M_PI), 0.0, 1.0);
  VisiblePolygon& vis = scratch;
  if (!visible_polygon(receiver, v, n, vis)) return 0.0;
  const Vec3& N = receiver.normal;
  bool centered = false;
  if (vis.whole) {
    // Differences from the input coordinates: exact shape even when p is far from the polygon.
    const Vec3 c = vis.a[0];
    relative.resize(vis.a.size());
    double rmax2 = 0.0;
    for (int i = 0; i < n; ++i) {
      relative[i] = v[i] - v[0];
      rmax2 = std::max(rmax2, relative[i].squaredNorm());
    }
    if (kCentredFactor * rmax2 <= c.squaredNorm()) {
      sum = centered_sum(c, relative, N);
      centered = true;
    }
  }
  if (!centered) sum = edge_angle_sum(vis.a, N);  // the direct form: Ω_i/|a_i × a_{i+1}| times (a_i × a_{i+1})·N
  return std::clamp(-sum / (2.0 * M_PI), 0.0, 1.0);
}

}  // namespace photometria
