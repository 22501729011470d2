// Lambert's closed form: the form factor from a differential receiver area to a polygon.
//
//   F(dA -> P) = (1/π) ∫_P cos θ dω  over the part of P above the receiver's tangent plane
//             = -1/(2π) Σ_i Θ_i  N · (a_i × a_{i+1}) / |a_i × a_{i+1}|,   a_i = v_i - p,
//   Θ_i = atan2(|a_i × a_{i+1}|, a_i · a_{i+1})
// E. Heitz, "Geometric Derivation of the Irradiance of Polygonal Lights", Unity Technologies
// research report, 2017, eq. (1); M. M. Stark, "Vertex-Based Formulations of Irradiance from
// Polygonal Sources", University of Utah tech. report UUCS-00-012, 2000, eq. (3); Lambert 1760.
// (Full references: docs/theory.md "References".)
// The minus sign: with vertices counter-clockwise seen from the front, the edge normals
// a_i × a_{i+1} are the outward normals of the cone through the polygon (Stark, after eq. 3).
//
// Conventions (docs/theory.md "Units and conventions"):
//  - one-sided: a receiver behind the polygon's plane (seen from its back) gets 0;
//  - only the part above the receiver's tangent plane counts: the polygon is clipped to the
//    closed half-space N·(x - p) >= 0 first (Sutherland–Hodgman), a vertex on the plane is legal;
//  - angles by atan2, never acos of a dot product near ±1;
//  - edge normals formed as a_i × (v_{i+1} - v_i), which stays accurate when the receiver is
//    close to the edge's line (a_i and a_{i+1} nearly antiparallel);
//  - a receiver exactly on the polygon's boundary (edge or vertex, hence in its plane) gets the
//    limit value as the receiver is approached from `approach` (a direction in the receiver plane
//    pointing to where the receiver's own surface lies); by default from the polygon's front,
//    along its normal projected into the receiver plane. A receiver in the polygon's plane but
//    off its boundary sees zero solid angle: F = 0. The result is always finite, in [0, 1].
#pragma once

#include "geometry/polygon.h"

namespace photometria {

struct Receiver {
  Vec3 point;                    // p, metres
  Vec3 normal;                   // N, unit length
  Vec3 approach = Vec3::Zero();  // optional limit direction for p on the polygon's boundary
};

// F(dA -> polygon), dimensionless, in [0, 1]. `polygon` has n >= 3 vertices, counter-clockwise
// seen from its emitting (front) side; it may be non-convex but must be simple and planar.
double lambert_form_factor(const Receiver& receiver, const Vec3* polygon, int n);
inline double lambert_form_factor(const Receiver& receiver, const Polygon& polygon) {
  return lambert_form_factor(receiver, polygon.data(), static_cast<int>(polygon.size()));
}

}  // namespace photometria
