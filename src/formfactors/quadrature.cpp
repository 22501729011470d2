#include "formfactors/quadrature.h"

#include <cmath>
#include <stdexcept>

namespace photometria {

void gauss_legendre_unit(int n, std::vector<double>& nodes, std::vector<double>& weights) {
  nodes.assign(n, 0.0);
  weights.assign(n, 0.0);
  // Newton iteration on P_n from the Tricomi initial guess; weights 2 / ((1 - x²) P_n'(x)²)
  // (Abramowitz & Stegun 25.4.29), then mapped from [-1, 1] to [0, 1].
  for (int i = 0; i < n; ++i) {
    double x = std::cos(M_PI * (i + 0.75) / (n + 0.5));
    double dp = 1.0;
    for (int iter = 0; iter < 100; ++iter) {
      double p0 = 1.0, p1 = x;
      for (int k = 2; k <= n; ++k) {
        const double pk = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = pk;
      }
      const double pn = n == 1 ? x : p1;
      const double pn1 = n == 1 ? 1.0 : p0;
      dp = n * (x * pn - pn1) / (x * x - 1.0);
      const double dx = pn / dp;
      x -= dx;
      if (std::abs(dx) < 1e-16) break;
    }
    nodes[i] = 0.5 * (1.0 - x);
    weights[i] = 1.0 / ((1.0 - x * x) * dp * dp);  // = (2 / ((1-x²)P'²)) / 2 for the [0,1] map
  }
}

std::vector<QuadraturePoint> patch_quadrature(const Vec3* c, int corner_count, int order) {
  std::vector<QuadraturePoint> out;
  if (order <= 1) {
    Polygon poly(c, c + corner_count);
    out.push_back({polygon_centroid(poly), 1.0});
    return out;
  }
  std::vector<double> x, w;
  gauss_legendre_unit(order, x, w);
  double total = 0.0;
  for (int a = 0; a < order; ++a)
    for (int b = 0; b < order; ++b) {
      const double s = x[a], t = x[b];
      Vec3 p, ds, dt;
      if (corner_count == 4) {  // bilinear map of the unit square
        p = (1 - s) * (1 - t) * c[0] + s * (1 - t) * c[1] + s * t * c[2] + (1 - s) * t * c[3];
        ds = (1 - t) * (c[1] - c[0]) + t * (c[2] - c[3]);
        dt = (1 - s) * (c[3] - c[0]) + s * (c[2] - c[1]);
      } else {  // Duffy: (s, t) -> c0 + s (c1 - c0) + s t (c2 - c1)
        p = c[0] + s * (c[1] - c[0]) + s * t * (c[2] - c[1]);
        ds = (c[1] - c[0]) + t * (c[2] - c[1]);
        dt = s * (c[2] - c[1]);
      }
      const double jac = ds.cross(dt).norm();
      out.push_back({p, w[a] * w[b] * jac});
      total += w[a] * w[b] * jac;
    }
  if (total <= 0) throw std::invalid_argument("patch_quadrature: degenerate patch");
  for (auto& q : out) q.weight /= total;
  return out;
}

}  // namespace photometria
