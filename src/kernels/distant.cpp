#include "kernels/distant.h"

#include <algorithm>
#include <cmath>

#include "kernels/sphere.h"

namespace photometria {
namespace {

// sin and cos of θmax = angle_deg/2 degrees, exact at 90° (angle 180°).
void half_angle_sincos(double angle_deg, double& s, double& c) {
  const double half = 0.5 * angle_deg;
  if (half == 90.0) {
    s = 1.0;
    c = 0.0;
    return;
  }
  const double rad = half * (M_PI / 180.0);
  s = std::sin(rad);
  c = std::cos(rad);
  if (half >= 180.0) s = 0.0;  // the whole sphere
}

}  // namespace

double distant_form_factor(const Receiver& receiver, const Vec3& direction, double angle_deg) {
  if (!(angle_deg > 0.0)) return 0.0;
  const double len = direction.norm();
  if (len == 0.0) return 0.0;
  double s, c;
  half_angle_sincos(angle_deg, s, c);
  const double sin_beta = std::clamp(receiver.normal.dot(direction) / len, -1.0, 1.0);
  return spherical_cap_form_factor(s, c, sin_beta);
}

double distant_size_factor(double angle_deg) {
  if (!(angle_deg > 0.0)) return 1.0;  // UsdLux note (distant.h): sizeFactor(0) = 1
  double s, c;
  half_angle_sincos(angle_deg, s, c);
  return c >= 0.0 ? M_PI * s * s : M_PI * (2.0 - s * s);  // UsdLux note, both branches
}

double distant_irradiance(const Receiver& receiver, const Vec3& direction, double angle_deg, double intensity,
                          bool normalize) {
  const double len = direction.norm();
  if (len == 0.0) return 0.0;
  if (!(angle_deg > 0.0)) return intensity * std::max(0.0, receiver.normal.dot(direction) / len);
  const double radiance = normalize ? intensity / distant_size_factor(angle_deg) : intensity;
  return M_PI * distant_form_factor(receiver, direction, angle_deg) * radiance;
}

}  // namespace photometria
