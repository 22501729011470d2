#include "kernels/approximations.h"

#include <algorithm>
#include <cmath>

namespace photometria {
namespace {

// Vertices relative to the receiver; false when the receiver sees the polygon's back (or the
// polygon is degenerate): the one-sided rule shared by every kernel.
bool front_relative(const Receiver& r, const Vec3* v, int n, Polygon& a, Vec3& front) {
  if (n < 3) return false;
  a.resize(n);
  Vec3 mean = Vec3::Zero();
  for (int i = 0; i < n; ++i) {
    a[i] = v[i] - r.point;
    mean += a[i];
  }
  const Vec3 newell = newell_vector(a);
  const double len = newell.norm();
  if (len == 0.0) return false;
  front = newell / len;
  return -front.dot(mean) > 0.0;  // p strictly in front of the polygon's (mean) plane
}

thread_local Polygon scratch;

}  // namespace

double point_source_form_factor(const Receiver& r, const Vec3* v, int n) {
  Vec3 front;
  if (!front_relative(r, v, n, scratch, front)) return 0.0;
  const Vec3 c = polygon_centroid(scratch);  // relative to p
  const double d2 = c.squaredNorm();
  if (d2 == 0.0) return 0.0;
  const double d = std::sqrt(d2);
  const double area = polygon_area(scratch);
  const double cos_r = std::max(0.0, r.normal.dot(c) / d);
  const double cos_s = std::max(0.0, -front.dot(c) / d);
  return area * cos_r * cos_s / (M_PI * d2);  // Lawlor 2007 (approximations.h), inverse-square law
}

double tampieri_form_factor(const Receiver& r, const Vec3* v, int n) {
  Vec3 front;
  if (!front_relative(r, v, n, scratch, front)) return 0.0;
  Vec3 phi = Vec3::Zero();
  for (int i = 0; i < n; ++i) {
    const Vec3 ri = (-scratch[i]).normalized();            // R_i = normalize(receiver − light[i])
    const Vec3 rp = (-scratch[(i + 1) % n]).normalized();  // R_p, the next vertex
    const Vec3 cross = ri.cross(rp);
    if (cross.norm() == 0.0) continue;
    phi += std::acos(std::clamp(ri.dot(rp), -1.0, 1.0)) * cross.normalized();  // Lawlor 2007's code
  }
  return -r.normal.dot(phi) / (2.0 * M_PI);
}

double cross_product_form_factor(const Receiver& r, const Vec3* v, int n) {
  Vec3 front;
  if (!front_relative(r, v, n, scratch, front)) return 0.0;
  Vec3 phi = Vec3::Zero();
  for (int i = 0; i < n; ++i)
    phi += (-scratch[i]).normalized().cross((-scratch[(i + 1) % n]).normalized());  // Lawlor 2007
  return -r.normal.dot(phi) / (2.0 * M_PI);
}

}  // namespace photometria
