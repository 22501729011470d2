// Receiver cells: a convex receiver region as triangles and quads, each a map from the unit
// parameter square, for the integration rules of pair_integration.h and occluded_row.h.
//
//   ∫_cell f dA = ∫_0^1 ∫_0^1 f(x(s, t)) J(s, t) ds dt
// with the bilinear map on quads and the collapsed (Duffy) map on triangles,
// x = c0 + s (c1 − c0) + s t (c2 − c1), J = |∂x/∂s × ∂x/∂t| (M. G. Duffy, "Quadrature over a
// pyramid or cube of integrands with a singularity at a vertex", SIAM J. Numer. Anal. 19(6), 1982).
#pragma once

#include <algorithm>
#include <vector>

#include "geometry/polygon.h"

namespace photometria {

struct ReceiverCell {
  Vec3 c[4];
  int n;  // 3 (Duffy) or 4 (bilinear)
  // Position and area element at parameters (s, t) in [0, 1]².
  Vec3 at(double s, double t, double* jac) const {
    Vec3 ds, dt, p;
    if (n == 4) {
      p = (1 - s) * (1 - t) * c[0] + s * (1 - t) * c[1] + s * t * c[2] + (1 - s) * t * c[3];
      ds = (1 - t) * (c[1] - c[0]) + t * (c[2] - c[3]);
      dt = (1 - s) * (c[3] - c[0]) + s * (c[2] - c[1]);
    } else {
      p = c[0] + s * (c[1] - c[0]) + s * t * (c[2] - c[1]);
      ds = (c[1] - c[0]) + t * (c[2] - c[1]);
      dt = s * (c[2] - c[1]);
    }
    *jac = ds.cross(dt).norm();
    return p;
  }
  // The image of the parameter box [s0, s1] × [t0, t1]: a convex quad (a triangle where the
  // Duffy map collapses s = 0), corners into `out`; returns their count. Lines of constant s or
  // t map to segments under both maps, so these corners bound the image exactly.
  int box_corners(double s0, double s1, double t0, double t1, Vec3* out) const {
    double jac;
    int k = 0;
    const double s[4] = {s0, s1, s1, s0}, t[4] = {t0, t0, t1, t1};
    for (int i = 0; i < 4; ++i) {
      const Vec3 p = at(s[i], t[i], &jac);
      if (k > 0 && (p - out[k - 1]).squaredNorm() == 0.0) continue;
      out[k++] = p;
    }
    if (k > 1 && (out[k - 1] - out[0]).squaredNorm() == 0.0) --k;
    return k;
  }
};

// Cells covering a convex polygon: the polygon itself if it is a triangle or quad, else a fan of
// triangles from its first corner.
inline std::vector<ReceiverCell> receiver_cells(const Polygon& p) {
  std::vector<ReceiverCell> cells;
  if (p.size() == 3 || p.size() == 4) {
    ReceiverCell c{};
    c.n = static_cast<int>(p.size());
    std::copy(p.begin(), p.end(), c.c);
    cells.push_back(c);
    return cells;
  }
  for (size_t k = 1; k + 1 < p.size(); ++k) cells.push_back(ReceiverCell{{p[0], p[k], p[k + 1], Vec3::Zero()}, 3});
  return cells;
}

}  // namespace photometria
