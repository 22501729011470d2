#include "kernels/stark.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "kernels/visible_polygon.h"

namespace photometria {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();

thread_local VisiblePolygon scratch;
thread_local Polygon relative;  // r_i = v_i − v_0 from the input coordinates

// atan(t)/t − 1 = −t²/3 + t⁴/5 − t⁶/7 + …  for |t| < 0.2 (12 terms: error < 1e-17 relative).
double atan_ratio_minus_one(double t) {
  const double t2 = t * t;
  double s = 0.0;
  for (int k = 12; k >= 1; --k) s = t2 * ((k % 2 == 0 ? 1.0 : -1.0) / (2 * k + 1) + s);
  return s;
}

// a_j × a_{j+1} = a_j × e = a_{j+1} × e (e = a_{j+1} − a_j), formed on the shorter of the two
// vertex vectors: e = a_{j+1} − a_j keeps the digits of the longer one only, and the edge normal
// of a_j × (v_{j+1} − v_j) stays accurate for p close to the edge's line (the numerics rules of
// docs/theory.md).
inline Vec3 edge_normal(const Vec3& aj, const Vec3& ak, const Vec3& e) {
  const Vec3& base = aj.squaredNorm() <= ak.squaredNorm() ? aj : ak;
  return base.cross(e);
}

// The centred evaluations need a polygon that is small against its distance: every vertex within
// |c|/16 of vertex 0 (c = v_0 − p), with the differences r_i = v_i − v_0 taken from the input
// coordinates (exact shape even when p is far away). Fills `relative`; false if not applicable.
bool small_and_far(const VisiblePolygon& vis, const Vec3* v, int n) {
  if (!vis.whole) return false;
  relative.resize(n);
  double rmax2 = 0.0;
  for (int i = 0; i < n; ++i) {
    relative[i] = v[i] - v[0];
    rmax2 = std::max(rmax2, relative[i].squaredNorm());
  }
  return 256.0 * rmax2 <= vis.a[0].squaredNorm();
}

// ---------------------------------------------------------------------------------------------
// stark-vertex
// ---------------------------------------------------------------------------------------------

// Per edge j (from a_j to a_{j+1}): the cosine of eq. (13) and the angles of the edge's two ends
// measured from the edge's reference (see stark_vertex_direct).
struct EdgeAngles {
  double cos_n = 0.0;  // N·n̂_j, n̂_j = (a_j × e_j)/|a_j × e_j|   (eq. 13)
  double phi0 = 0.0;   // angle of a_j from the reference, positive along e_j
  double phi1 = 0.0;   // angle of a_{j+1}
  bool live = false;   // false: zero-length edge or edge along a view ray (no angle swept)
};
thread_local std::vector<EdgeAngles> edge_angles;

// Σ over vertices of [φ(a_i; edge i) N·n̂_i − φ(a_i; edge i−1) N·n̂_{i−1}]   (eqs. 12, 44).
double vertex_sum(const std::vector<EdgeAngles>& edges) {
  const size_t n = edges.size();
  double sum = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const EdgeAngles& out = edges[i];
    const EdgeAngles& in = edges[(i + n - 1) % n];
    double term = 0.0;
    if (out.live) term += out.phi0 * out.cos_n;
    if (in.live) term -= in.phi1 * in.cos_n;
    sum += term;
  }
  return sum;
}

// Direct evaluation of eq. (12) in eq. (11)'s coordinates of each edge: h = |a × ê| (the distance
// of p from the edge's line, the same at both ends) and t = a·ê, so that ∠(a, ê) = atan2(h, t).
// Eq. (11) measures both ends from ê (Fig. 5b), which makes every vertex term O(1) even when the
// edge subtends a tiny angle. Any reference in the edge's plane serves (Fig. 5a): the per-edge
// constant it adds cancels between the edge's two ends. For an edge subtending at most 90°
// (a_j·a_{j+1} >= 0) the reference is the edge's midpoint m, whose direction is then accurate
// (|m| >= max |a|/2), and the angles follow from the arctangent subtraction formula
//   ∠(m, ê) − ∠(a, ê) = atan2(h (t_a − t_m), h² + t_a t_m),   h² + t_a t_m = m·a;
// a wider edge keeps eq. (11)'s ê (its angle is O(1) anyway).
double stark_vertex_direct(const Polygon& a, const Vec3& N) {
  const size_t n = a.size();
  std::vector<EdgeAngles>& edges = edge_angles;
  edges.resize(n);
  for (size_t j = 0; j < n; ++j) {
    const Vec3& aj = a[j];
    const Vec3& ak = a[(j + 1) % n];
    const Vec3 e = ak - aj;
    const Vec3 axe = edge_normal(aj, ak, e);  // a_j × e_j
    const double hl = axe.norm();
    EdgeAngles& E = edges[j];
    E.live = hl != 0.0;
    if (!E.live) continue;
    const double l = e.norm();
    const double h = hl / l;
    const double t0 = aj.dot(e) / l;  // a_j·ê_j
    const double t1 = ak.dot(e) / l;  // a_{j+1}·ê_j
    E.cos_n = N.dot(axe) / hl;
    if (aj.dot(ak) >= 0.0) {
      const double tm = 0.5 * (t0 + t1);
      E.phi0 = std::atan2(-0.5 * hl, h * h + t0 * tm);
      E.phi1 = std::atan2(0.5 * hl, h * h + t1 * tm);
    } else {
      E.phi0 = -std::atan2(h, t0);  // −∠(a_j, ê_j)      (eq. 11)
      E.phi1 = -std::atan2(h, t1);  // −∠(a_{j+1}, ê_j)
    }
  }
  return vertex_sum(edges);
}

// Centred evaluation of the same vertex sum (see stark.h). With c = a_0, r_i = v_i − v_0,
// w̄ = 1/|c|², the reference of edge j is its midpoint m_j = c + ρ_j, ρ_j = (r_j + r_{j+1})/2, and
// a vertex's angle term is the vector  φ n̂_j = ω (m_j × δ),  δ = a_i − m_j = ∓e_j/2,
// ω = φ/|m_j × δ| = (atan τ/τ)/(m_j·a_i),  τ = tan φ = |m_j × δ|/(m_j·a_i). The part w̄ c × δ of
// every term sums to w̄ c × Σ_i (ρ_{i−1} − ρ_i) = 0 over the closed polygon and is left out; what
// remains, (ω − w̄) c × δ + ω ρ_j × δ,   ρ_j × δ = ∓(r_j × r_{j+1})/2,
// is of the order of the result and formed without cancellation.
double stark_vertex_centred(const Vec3& c, const Polygon& r, const Vec3& N) {
  const size_t n = r.size();
  const double cc = c.squaredNorm();
  // Per edge: half of c × e_j and of ρ_j × e_j = r_j × r_{j+1}, and the two weights ω − w̄, ω.
  struct Half {
    Vec3 cxe, rxr;
    double dw0, w0, dw1, w1;
  };
  thread_local std::vector<Half> halves;
  halves.resize(n);
  for (size_t j = 0; j < n; ++j) {
    const Vec3& r0 = r[j];
    const Vec3& r1 = r[(j + 1) % n];
    const Vec3 e = r1 - r0;
    const Vec3 rho = 0.5 * (r0 + r1);
    Half& H = halves[j];
    H.cxe = 0.5 * c.cross(e);
    H.rxr = 0.5 * r0.cross(r1);
    const double half_hl = (H.cxe + H.rxr).norm();  // |m_j × δ| = h_j ℓ_j / 2
    auto weights = [&](const Vec3& ri, double& dw, double& w) {
      const double delta = c.dot(rho + ri) + rho.dot(ri);    // m_j·a_i − |c|², no cancellation
      const double dot = cc + delta;                         // m_j·a_i > 0 here
      const double g = atan_ratio_minus_one(half_hl / dot);  // atan τ/τ − 1
      w = (1.0 + g) / dot;                                   // ω
      dw = g / dot - delta / (dot * cc);                     // ω − w̄
    };
    weights(r0, H.dw0, H.w0);
    weights(r1, H.dw1, H.w1);
  }
  // Vertex i: the term of its outgoing edge (δ = −e_i/2) minus that of its incoming edge
  // (δ = +e_{i−1}/2), each without its w̄ c × δ part.
  Vec3 sum = Vec3::Zero();
  for (size_t i = 0; i < n; ++i) {
    const Half& out = halves[i];
    const Half& in = halves[(i + n - 1) % n];
    const Vec3 t_out = -(out.dw0 * out.cxe + out.w0 * out.rxr);
    const Vec3 t_in = in.dw1 * in.cxe + in.w1 * in.rxr;
    sum += t_out - t_in;
  }
  return N.dot(sum);
}

// ---------------------------------------------------------------------------------------------
// stark-image
// ---------------------------------------------------------------------------------------------

thread_local std::vector<double> heights;

// Direct evaluation of eq. (44) in homogeneous coordinates (see stark.h).
double stark_image_direct(const Polygon& a, const Vec3& N) {
  const size_t n = a.size();
  std::vector<double>& W = heights;
  W.resize(n);
  for (size_t i = 0; i < n; ++i) {
    W[i] = N.dot(a[i]);  // homogeneous coordinate W: the height above the receiver plane
    // On the receiver plane up to the rounding of the clip: a point at infinity (sec. 6.4).
    if (W[i] <= 8.0 * kEps * a[i].norm()) W[i] = 0.0;
  }
  std::vector<EdgeAngles>& edges = edge_angles;
  edges.resize(n);
  for (size_t j = 0; j < n; ++j) {
    const size_t k = (j + 1) % n;
    const Vec3& aj = a[j];
    const Vec3& ak = a[k];
    const Vec3 e = ak - aj;
    const Vec3 line = edge_normal(aj, ak, e);  // homogeneous line through both vertices, a_j × a_{j+1}
    const double len = line.norm();
    EdgeAngles& E = edges[j];
    E.live = len != 0.0;  // zero-length edge, or edge along a view ray: no angle swept
    if (!E.live) continue;
    const Vec3 n_hat = line / len;
    E.cos_n = N.dot(n_hat);                 // = −C (a y − b x) of eq. (45)
    const bool narrow = aj.dot(ak) >= 0.0;  // the edge subtends at most 90°
    const bool at_infinity = W[j] == 0.0 && W[k] == 0.0;
    if (at_infinity || 1.0 - E.cos_n * E.cos_n < 0.25) {
      // Edge at infinity (both ends on the receiver plane), or an image line farther than √3
      // from the image origin, where the tangents from the acme are ill-conditioned: angles in
      // the edge's own plane, as eq. (46) measures them.
      if (narrow) {  // from the midpoint m: atan2((m × a)·n̂, m·a), m × a_{j+1} = −m × a_j = line/2
        const Vec3 m = aj + 0.5 * e;
        E.phi0 = std::atan2(-0.5 * len, m.dot(aj));
        E.phi1 = std::atan2(0.5 * len, m.dot(ak));
      } else {  // eq. (46): from the perpendicular to the edge vector d, atan((d·Q)/|d × Q|)
        const double l = e.norm(), h = len / l;
        E.phi0 = std::atan2(aj.dot(e) / l, h);
        E.phi1 = std::atan2(ak.dot(e) / l, h);
      }
      continue;
    }
    const Vec3 q = n_hat.cross(N);  // N·(a × n̂) = q·a
    if (!narrow) {
      // Eq. (45) as printed: the tangent from the acme, C(a x + b y) = N·(a × n̂)/W; at W = 0 (a
      // vertex at infinity) atan2 gives Fig. 11's ±π/2 without a special case.
      E.phi0 = std::atan2(q.dot(aj), W[j]);
      E.phi1 = std::atan2(q.dot(ak), W[k]);
      continue;
    }
    // Measured from the homogeneous midpoint m = (a_j + a_{j+1})/2 by the arctangent subtraction
    // formula, atan u − atan u_m = atan2(u − u_m, 1 + u u_m), multiplied through by W W_m >= 0:
    // numerator N·((a W_m − m W) × n̂), a W_m − m W = δ W_m − m (N·δ), δ = a − m = ±e/2 (the
    // homogeneous difference of the two image points, without cancellation).
    const Vec3 m = aj + 0.5 * e;
    const double Wm = 0.5 * (W[j] + W[k]);
    const double qe = 0.5 * q.dot(e), Ne = 0.5 * N.dot(e), qm = q.dot(m);  // qm = u_m W_m
    const bool short_edge = e.squaredNorm() <= 4.0 * std::min(aj.squaredNorm(), ak.squaredNorm());
    auto psi = [&](const Vec3& ai, double Wa, double sign) {
      // q·(a W_m − m W) from whichever of δ = ±e/2 and a is shorter (for a vertex much closer to
      // p than the other its own coordinates carry its direction; δ would lose it).
      const double num = short_edge ? sign * (Wm * qe - Ne * qm) : Wm * q.dot(ai) - Wa * qm;
      return std::atan2(num, Wa * Wm + q.dot(ai) * qm);
    };
    E.phi0 = psi(aj, W[j], -1.0);
    E.phi1 = psi(ak, W[k], 1.0);
  }
  // Σ_i [G(v_i; edge i−1) − G(v_i; edge i)] with G(a; j) = −(N·n̂_j) φ_j(a)   (eq. 44).
  return vertex_sum(edges);
}

// Centred evaluation of eq. (44) in homogeneous coordinates (see stark.h): every vertex is
// represented by its own position a_i = c + r_i (homogeneous coordinates may have any positive
// scale; this one keeps the Euclidean metric isotropic), the line of edge j is
// l_j = a_j × a_{j+1} = c × e_j + r_j × r_{j+1}, and the end term of eq. (45) measured from the
// homogeneous midpoint m_j is the vector −ψ l̂_j with  ψ l̂_j = ω (m_j × δ) = ±ω l_j/2,
// ω = ψ/|m_j × δ| = (atan τ/τ)/(m_j·a),  τ = tan ψ from the tangents of eq. (45).
// The part ±w̄ c × e_j/2 of every term sums to ±w̄ c × Σ e_j = 0 and is left out.
double stark_image_centred(const Vec3& c, const Polygon& r, const Polygon& a, const Vec3& N) {
  const size_t n = r.size();
  const double cc = c.squaredNorm();
  Vec3 sum = Vec3::Zero();
  for (size_t j = 0; j < n; ++j) {
    const size_t k = (j + 1) % n;
    const Vec3& r0 = r[j];
    const Vec3& r1 = r[k];
    const Vec3 e = r1 - r0;
    const Vec3 l_c = c.cross(e);    // the part of the line that sums to zero
    const Vec3 l_r = r0.cross(r1);  // the rest: l_j = l_c + l_r
    const Vec3 line = l_c + l_r;
    const double len = line.norm();
    if (len == 0.0) continue;  // zero-length edge, or edge along a view ray
    const Vec3 n_hat = line / len;
    const double cos_n = N.dot(n_hat);
    const Vec3 rho = 0.5 * (r0 + r1);
    const Vec3 m = c + rho;  // homogeneous midpoint
    const double Wm = N.dot(m);
    const bool tangents = Wm > 0.0 && 1.0 - cos_n * cos_n >= 0.25;
    const Vec3 q = n_hat.cross(N);  // N·(a × n̂) = q·a: u = q·a/W (eq. 45: C(a x + b y) = u)
    const double qm = q.dot(m);     // u_m W_m
    // End s = −1 (vertex j, outgoing) or +1 (vertex j+1, incoming).
    for (const double s : {-1.0, 1.0}) {
      const Vec3& ri = s < 0 ? r0 : r1;
      const Vec3& ai = s < 0 ? a[j] : a[k];
      const double delta_dot = c.dot(rho + ri) + rho.dot(ri);  // m·a − |c|², no cancellation
      const double dot = cc + delta_dot;                       // m·a > 0 here
      double tau;                                              // tan ψ
      if (tangents) {
        // (u − u_m)/(1 + u u_m) × W W_m, with q·(a W_m − m W) = q·(δ W_m − m N·δ), δ = ±e/2
        tau = (0.5 * s) * (Wm * q.dot(e) - N.dot(e) * qm) / (N.dot(ai) * Wm + q.dot(ai) * qm);
      } else {
        tau = s * 0.5 * len / dot;  // measured in the edge's plane, as eq. (46)
      }
      const double g = atan_ratio_minus_one(tau);
      const double w = (1.0 + g) / dot;                    // ω
      const double dw = g / dot - delta_dot / (dot * cc);  // ω − w̄
      // G(a; j) without its leading part: −(s/2)[(ω − w̄) l_c + ω l_r]. Vertex i gets
      // G(a_i; i−1) − G(a_i; i): the end term (s = +1) with +, the start term (s = −1) with −.
      const Vec3 G = -(0.5 * s) * (dw * l_c + w * l_r);
      sum += s > 0 ? G : Vec3(-G);
    }
  }
  return N.dot(sum);
}

}  // namespace

double stark_vertex_form_factor(const Receiver& receiver, const Vec3* v, int n) {
  VisiblePolygon& vis = scratch;
  if (!visible_polygon(receiver, v, n, vis)) return 0.0;
  const double sum = small_and_far(vis, v, n) ? stark_vertex_centred(vis.a[0], relative, receiver.normal)
                                              : stark_vertex_direct(vis.a, receiver.normal);
  return std::clamp(sum / (2.0 * M_PI), 0.0, 1.0);
}

double stark_image_form_factor(const Receiver& receiver, const Vec3* v, int n) {
  VisiblePolygon& vis = scratch;
  if (!visible_polygon(receiver, v, n, vis)) return 0.0;
  const double sum = small_and_far(vis, v, n) ? stark_image_centred(vis.a[0], relative, vis.a, receiver.normal)
                                              : stark_image_direct(vis.a, receiver.normal);
  return std::clamp(sum / (2.0 * M_PI), 0.0, 1.0);
}

}  // namespace photometria
