#include "kernels/sphere.h"

#include <algorithm>
#include <cmath>

#include "kernels/lambert.h"

namespace photometria {
namespace {

// t − atan t = t³/3 − t⁵/5 + t⁷/7 − …  for 0 <= t < 0.2 (14 terms: error < 1e-19 relative).
double t_minus_atan(double t) {
  const double t2 = t * t;
  double s = 0.0;
  for (int k = 14; k >= 1; --k) s = t2 * ((k % 2 == 1 ? 1.0 : -1.0) / (2 * k + 1) + s);
  return t * s;
}

// σ <= π/2 (cos_sigma >= 0).
double cap_upper(double ss, double cs, double sb) {
  if (ss <= 0.0) return 0.0;
  if (sb >= ss) return ss * ss * sb;  // wholly above: Heitz 2017 eq. (16)
  if (sb <= -ss) return 0.0;          // wholly below
  // Crossing the horizon: Howell B-43, rewritten (see sphere.h).
  const double R = std::sqrt((ss - sb) * (ss + sb));
  double t13;  // atan t − t cos²σ
  if (cs > 0.0 && R < 0.2 * cs) {
    const double t = R / cs;
    t13 = t * ss * ss - t_minus_atan(t);
  } else {
    t13 = std::atan2(R, cs) - R * cs;
  }
  const double t2 = ss * ss * sb * std::atan2(R, -sb * cs);
  return std::clamp((t13 + t2) / M_PI, 0.0, 1.0);
}

}  // namespace

double spherical_cap_form_factor(double sin_sigma, double cos_sigma, double sin_beta) {
  if (cos_sigma >= 0.0) return cap_upper(sin_sigma, cos_sigma, sin_beta);
  // Wider than a hemisphere: everything above the horizon minus the complementary cap.
  return std::clamp(1.0 - cap_upper(sin_sigma, -cos_sigma, -sin_beta), 0.0, 1.0);
}

double sphere_form_factor(const Receiver& receiver, const Vec3& center, double radius) {
  const Vec3 rel = center - receiver.point;  // relative to the receiver
  const double d = rel.norm();
  if (radius <= 0.0) return 0.0;
  if (d <= radius) return std::clamp(0.5 * (1.0 + (d > 0 ? receiver.normal.dot(rel) / d : 0.0)), 0.0, 1.0);
  const double ss = radius / d;                                  // sin σ = r/d
  const double cs = std::sqrt((d - radius) * (d + radius)) / d;  // cos σ without cancellation
  return spherical_cap_form_factor(ss, cs, std::clamp(receiver.normal.dot(rel) / d, -1.0, 1.0));
}

}  // namespace photometria
