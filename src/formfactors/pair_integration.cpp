#include "formfactors/pair_integration.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "formfactors/quadrature.h"
#include "formfactors/receiver_cells.h"
#include "kernels/lambert.h"

namespace photometria {
namespace {

using Cell = ReceiverCell;

struct Integrator {
  const Vec3& normal;
  const Vec3* source;
  int source_count;
  long long evaluations = 0;
  std::vector<double> x4, w4;

  Integrator(const Vec3& n, const Vec3* s, int sc) : normal(n), source(s), source_count(sc) {
    gauss_legendre_unit(4, x4, w4);
  }

  double kernel(const Vec3& p) {
    ++evaluations;
    return lambert_form_factor(Receiver{p, normal}, source, source_count);
  }

  // ∫ F dA over the parameter box [s0,s1]×[t0,t1] of a cell with an n × n Gauss rule.
  double box(const Cell& cell, double s0, double s1, double t0, double t1, const std::vector<double>& x,
             const std::vector<double>& w) {
    double sum = 0.0;
    for (size_t a = 0; a < x.size(); ++a)
      for (size_t b = 0; b < x.size(); ++b) {
        double jac;
        const Vec3 p = cell.at(s0 + (s1 - s0) * x[a], t0 + (t1 - t0) * x[b], &jac);
        sum += w[a] * w[b] * jac * kernel(p);
      }
    return sum * (s1 - s0) * (t1 - t0);
  }

  // Adaptive anisotropic bisection; `whole` is the 4 × 4 estimate of this box.
  double adapt(const Cell& cell, double s0, double s1, double t0, double t1, double whole, double tol, int depth) {
    const double sm = 0.5 * (s0 + s1), tm = 0.5 * (t0 + t1);
    const double sa = box(cell, s0, sm, t0, t1, x4, w4), sb = box(cell, sm, s1, t0, t1, x4, w4);
    const double ta = box(cell, s0, s1, t0, tm, x4, w4), tb = box(cell, s0, s1, tm, t1, x4, w4);
    const double err_s = std::abs(sa + sb - whole), err_t = std::abs(ta + tb - whole);
    const bool split_s = err_s >= err_t;
    const double best = split_s ? sa + sb : ta + tb;
    if (std::max(err_s, err_t) <= tol || depth >= 40) return best;
    if (split_s)
      return adapt(cell, s0, sm, t0, t1, sa, 0.5 * tol, depth + 1) +
             adapt(cell, sm, s1, t0, t1, sb, 0.5 * tol, depth + 1);
    return adapt(cell, s0, s1, t0, tm, ta, 0.5 * tol, depth + 1) +
           adapt(cell, s0, s1, tm, t1, tb, 0.5 * tol, depth + 1);
  }
};

double bounding_radius(const Vec3* v, int n, const Vec3& centre) {
  double r = 0.0;
  for (int k = 0; k < n; ++k) r = std::max(r, (v[k] - centre).norm());
  return r;
}

}  // namespace

PairResult pair_form_factor(const Vec3* r, int rn, const Vec3& r_normal, const Vec3* s, int sn, const Vec3& s_normal,
                            double tolerance) {
  PairResult result;
  // 1. Keep the part of the receiver in front of the source's plane (relative to a source vertex).
  Polygon rel(rn), front;
  for (int k = 0; k < rn; ++k) rel[k] = r[k] - s[0];
  clip_to_halfspace(rel.data(), rn, s_normal, front);
  if (front.size() < 3) return result;
  for (Vec3& v : front) v += s[0];
  const double full_area = polygon_area(Polygon(r, r + rn));
  const double area = polygon_area(front);
  if (area <= 0.0 || full_area <= 0.0) return result;

  // 2. Distance ratio a = d / h between the receiver region and the source's bounding sphere.
  const Vec3 rc = polygon_centroid(front);
  const double h = bounding_radius(front.data(), static_cast<int>(front.size()), rc);
  Vec3 sc = Vec3::Zero();
  for (int k = 0; k < sn; ++k) sc += s[k];
  sc /= sn;
  const double d = (rc - sc).norm() - bounding_radius(s, sn, sc);
  const double a = d / h;

  Integrator integ(r_normal, s, sn);
  double integral = 0.0;
  if (a >= 1.5) {
    const double rho = a + std::sqrt(a * a - 1.0);
    const int n = std::clamp(static_cast<int>(std::ceil(std::log(10.0 / tolerance) / (2.0 * std::log(rho)))), 1, 16);
    std::vector<double> x, w;
    gauss_legendre_unit(n, x, w);
    for (const Cell& c : receiver_cells(front)) integral += integ.box(c, 0, 1, 0, 1, x, w);
    result.rule = PairRule::Gauss;
    result.order = n;
  } else {
    // 3. Touching or near: adaptive. Absolute target from a first estimate of F.
    const auto cells = receiver_cells(front);
    std::vector<double> first(cells.size());
    double estimate = 0.0;
    for (size_t k = 0; k < cells.size(); ++k)
      estimate += first[k] = integ.box(cells[k], 0, 1, 0, 1, integ.x4, integ.w4);
    const double tol_abs = tolerance * std::max(std::abs(estimate) / full_area, 1e-4) * full_area;
    for (size_t k = 0; k < cells.size(); ++k)
      integral += integ.adapt(cells[k], 0, 1, 0, 1, first[k], tol_abs / cells.size(), 0);
    result.rule = PairRule::Adaptive;
  }
  result.form_factor = std::clamp(integral / full_area, 0.0, 1.0);
  result.evaluations = integ.evaluations;
  return result;
}

}  // namespace photometria
