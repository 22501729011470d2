#include "geometry/polygon.h"

#include <algorithm>
#include <cmath>

namespace photometria {

Vec3 newell_vector(const Vec3* v, int n) {
  // Newell's method: sum of (v_i x v_{i+1}) taken relative to v_0 so that a polygon far from the
  // origin keeps its digits.
  Vec3 sum = Vec3::Zero();
  for (int i = 1; i + 1 < n; ++i) sum += (v[i] - v[0]).cross(v[i + 1] - v[0]);
  return sum;
}

Vec3 polygon_normal(const Polygon& p) {
  const Vec3 nv = newell_vector(p);
  const double len = nv.norm();
  return len > 0 ? Vec3(nv / len) : Vec3::Zero();
}

double polygon_area(const Polygon& p) { return 0.5 * newell_vector(p).norm(); }

Vec3 polygon_centroid(const Polygon& p) {
  const Vec3 n = polygon_normal(p);
  Vec3 weighted = Vec3::Zero();
  double total = 0.0;
  for (size_t i = 1; i + 1 < p.size(); ++i) {
    const double a = 0.5 * n.dot((p[i] - p[0]).cross(p[i + 1] - p[0]));  // signed: non-convex safe
    weighted += a * (p[0] + p[i] + p[i + 1]) / 3.0;
    total += a;
  }
  if (total == 0.0) {
    Vec3 mean = Vec3::Zero();
    for (const Vec3& v : p) mean += v;
    return p.empty() ? mean : Vec3(mean / double(p.size()));
  }
  return weighted / total;
}

double planarity_deviation(const Polygon& p) {
  if (p.size() < 4) return 0.0;
  const Vec3 n = polygon_normal(p);
  Vec3 mean = Vec3::Zero();
  for (const Vec3& v : p) mean += v;
  mean /= double(p.size());
  double worst = 0.0;
  for (const Vec3& v : p) worst = std::max(worst, std::abs(n.dot(v - mean)));
  return worst;
}

void clip_to_halfspace(const Vec3* in, int n, const Vec3& plane_normal, Polygon& out) {
  out.clear();
  for (int i = 0; i < n; ++i) {
    const Vec3& a = in[i];
    const Vec3& b = in[(i + 1) % n];
    const double ha = plane_normal.dot(a);
    const double hb = plane_normal.dot(b);
    if (ha >= 0) out.push_back(a);
    // A strict sign change: the edge crosses the plane in its interior.
    if ((ha > 0 && hb < 0) || (ha < 0 && hb > 0)) {
      const double t = ha / (ha - hb);
      Vec3 x = a + t * (b - a);
      // Put the new vertex exactly on the plane (it is the horizon point of the cone).
      x -= plane_normal.dot(x) * plane_normal / plane_normal.squaredNorm();
      out.push_back(x);
    }
  }
}

void clip_to_halfspace_at(const Vec3* v, int n, const Vec3& origin, const Vec3& normal, Polygon& out) {
  thread_local Polygon rel;
  rel.assign(v, v + n);
  for (Vec3& p : rel) p -= origin;
  clip_to_halfspace(rel.data(), n, normal, out);
  for (Vec3& p : out) p += origin;
}

namespace {
// 2-D coordinates of the polygon in its own plane.
std::vector<Eigen::Vector2d> project_to_plane(const Polygon& p, const Vec3& n) {
  const Vec3 u = (std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).cross(n).normalized();
  const Vec3 w = n.cross(u);
  std::vector<Eigen::Vector2d> q;
  q.reserve(p.size());
  for (const Vec3& v : p) q.emplace_back((v - p[0]).dot(u), (v - p[0]).dot(w));
  return q;
}

double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  return (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
}

bool inside_triangle(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                     const Eigen::Vector2d& c) {
  return cross2(a, b, p) >= 0 && cross2(b, c, p) >= 0 && cross2(c, a, p) >= 0;
}
}  // namespace

bool is_convex(const Polygon& p) {
  const Vec3 n = polygon_normal(p);
  if (n.isZero() || p.size() < 3) return false;
  for (size_t i = 0; i < p.size(); ++i) {
    const Vec3& a = p[i];
    const Vec3& b = p[(i + 1) % p.size()];
    const Vec3& c = p[(i + 2) % p.size()];
    if (n.dot((b - a).cross(c - b)) <= 0) return false;
  }
  return true;
}

std::vector<std::array<int, 3>> triangulate_polygon(const Polygon& p) {
  std::vector<std::array<int, 3>> tris;
  const Vec3 n = polygon_normal(p);
  if (p.size() < 3 || n.isZero()) return tris;
  const auto q = project_to_plane(p, n);
  std::vector<int> idx(p.size());
  for (size_t i = 0; i < p.size(); ++i) idx[i] = static_cast<int>(i);
  // Ear clipping (O(n^3) worst case; faces have few vertices).
  size_t guard = 0;
  while (idx.size() > 3 && guard++ < p.size() * p.size()) {
    bool clipped = false;
    for (size_t k = 0; k < idx.size(); ++k) {
      const int ia = idx[(k + idx.size() - 1) % idx.size()], ib = idx[k], ic = idx[(k + 1) % idx.size()];
      if (cross2(q[ia], q[ib], q[ic]) <= 0) continue;  // reflex or degenerate corner
      bool empty = true;
      for (int j : idx)
        if (j != ia && j != ib && j != ic && inside_triangle(q[j], q[ia], q[ib], q[ic])) {
          empty = false;
          break;
        }
      if (!empty) continue;
      tris.push_back({ia, ib, ic});
      idx.erase(idx.begin() + static_cast<long>(k));
      clipped = true;
      break;
    }
    if (!clipped) break;  // self-intersecting input: give up on the rest
  }
  if (idx.size() == 3) tris.push_back({idx[0], idx[1], idx[2]});
  return tris;
}

}  // namespace photometria
