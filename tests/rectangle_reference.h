// Reference: exact A1 F12 between axis-aligned rectangles by superposition of Howell's catalog
// cases C-11 (parallel rectangles) and C-14 (perpendicular rectangles with a common edge) —
// J. R. Howell, "A Catalog of Radiation Heat Transfer Configuration Factors", 3rd ed. — written
// out as in Ehlert & Smith, "View factors for perpendicular and parallel rectangular plates",
// J. Thermophysics Heat Transfer 7(1), 1993, eqs. 3–6, evaluated term by term in long double:
//   parallel, distance z:   A1 F12 = (1/2π) Σ_{ijkl} (−1)^{i+j+k+l} Gp(x_i − ξ_k, y_j − η_l, z)
//     Gp(x, y, z) = x √(y²+z²) atan(x/√(y²+z²)) + y √(x²+z²) atan(y/√(x²+z²)) − (z²/2) ln(x²+y²+z²)
//   perpendicular, common axis x, y and η distances from the common line:
//                           A1 F12 = (1/2π) Σ_{ijkl} (−1)^{i+j+k+l} Gq(x_i − ξ_k, y_j, η_l)
//     Gq(x, y, η) = x √(y²+η²) atan(x/√(y²+η²)) − ¼ (y² + η² − x²) ln(x² + y² + η²)
// Used by tests/test_viewfactors.cpp and tests/test_formfactors_rectangles.cpp as an evaluation
// independent of src/formfactors/aligned_rectangles (no tables, no double-double sums).
#pragma once

#include <cmath>

namespace rect_ref {

using ld = long double;
inline const ld kPi = 3.141592653589793238462643383279502884L;

inline ld gp(ld x, ld y, ld z) {
  ld t = 0;
  const ld a = std::sqrt(y * y + z * z), b = std::sqrt(x * x + z * z);
  if (a > 0) t += x * a * std::atan(x / a);
  if (b > 0) t += y * b * std::atan(y / b);
  const ld r = x * x + y * y + z * z;
  if (z != 0 && r > 0) t -= z * z / 2 * std::log(r);
  return t;
}

inline ld gq(ld x, ld y, ld e) {
  const ld c = y * y + e * e, r = x * x + c;
  ld t = 0;
  if (c > 0) t += x * std::sqrt(c) * std::atan(x / std::sqrt(c));
  if (r > 0) t -= 0.25L * (c - x * x) * std::log(r);
  return t;
}

// A1 F12 (m²) for [x0,x1]×[y0,y1] and [s0,s1]×[e0,e1] in parallel planes a distance z apart.
inline ld parallel_af(ld x0, ld x1, ld y0, ld y1, ld s0, ld s1, ld e0, ld e1, ld z) {
  const ld x[2] = {x0, x1}, y[2] = {y0, y1}, s[2] = {s0, s1}, e[2] = {e0, e1};
  ld sum = 0;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      for (int k = 0; k < 2; ++k)
        for (int l = 0; l < 2; ++l) sum += ((i + j + k + l) % 2 ? -1 : 1) * gp(x[i] - s[k], y[j] - e[l], z);
  return sum / (2 * kPi);
}

// A1 F12 (m²), perpendicular: x, s along the common axis, y, e distances from the common line.
inline ld perpendicular_af(ld x0, ld x1, ld y0, ld y1, ld s0, ld s1, ld e0, ld e1) {
  const ld x[2] = {x0, x1}, y[2] = {y0, y1}, s[2] = {s0, s1}, e[2] = {e0, e1};
  ld sum = 0;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      for (int k = 0; k < 2; ++k)
        for (int l = 0; l < 2; ++l) sum += ((i + j + k + l) % 2 ? -1 : 1) * gq(x[i] - s[k], y[j], e[l]);
  return sum / (2 * kPi);
}

}  // namespace rect_ref
