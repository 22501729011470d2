// Stark's vertex-based formulations of the point-to-polygon form factor (seed 002: M. Stark,
// "Vertex-Based Formulations of Irradiance from Polygonal Sources", UUCS-00-012, 2000). Both are
// sums over the vertices of the visible (clipped) polygon, equal to Lambert's edge sum; same
// conventions and domain as lambert_form_factor() (see visible_polygon.h). Results in [0, 1].
#pragma once

#include "kernels/lambert.h"

namespace photometria {

// Vertex-based reformulation of Lambert's formula, seed 002 eqs. (12)–(13):
//   F = (1/2π) Σ_i [ ∠(a_i, e_{i−1}) N·n̂_{i−1} − ∠(a_i, e_i) N·n̂_i ],
//   e_i = v_{i+1} − v_i,  n̂_i = (a_i × e_i)/|a_i × e_i|,  ∠ by atan2(|a × e|, a·e)  (eq. 11).
// Each edge's angle is a difference of two angles measured from the edge direction (eq. 11), so
// its terms are O(1) whatever F: absolute error ~ε, relative ~ε/F (a polygon 1e6 sizes away,
// F ~ 1e-13, keeps only ~4 digits).
double stark_vertex_form_factor(const Receiver& receiver, const Vec3* polygon, int n);

// Image-plane formula, seed 002 eqs. (8)–(10), in its projective / homogeneous form
// (eqs. 43–46, Fig. 10–11). The visible polygon is projected through p onto the plane one unit
// above the receiver (eq. 4): vertex a ↦ homogeneous point (X, Y, W) = (u·a, w·a, N·a), W = 0 for
// a vertex on the receiver plane (a "vertex at infinity", sec. 6.4); an edge is the homogeneous
// line l ∝ a_i × a_{i+1} through its two vertices, whose projective direction is Stark's (a, b).
// Eq. (45)'s vertex term G(x, y; a, b) = C (a y − b x) atan(C (a x + b y)) then reads
//   G = −(N·n̂) atan2(N·(a × n̂), W),   n̂ = l/|l|
// (C(a y − b x) = −N·n̂ is the cosine of eq. 29/32, C(a x + b y) = N·(a × n̂)/W the tangent of the
// angle from the edge's acme, eqs. 25/37); at W = 0 atan2 gives Fig. 11's "vertex at infinity"
// ±π/2 terms without a special case. An edge with both ends on the receiver plane (an "edge at
// infinity") uses eq. (46): atan((d·Q)/(N·(d × Q))), d = the edge vector. Then
//   F = (1/2π) Σ_i [G(v_i; edge i−1) − G(v_i; edge i)]     (eq. 44),
// evaluated edge by edge (the same terms regrouped). Written with the 3-D vertex instead of
// x = X/W, y = Y/W, it loses no digits for vertices close to the horizon (huge x, y).
// Like stark-vertex, its terms are O(1) angles, so its absolute error is ~ε: relative accuracy
// degrades like ε/F for small F.
double stark_image_form_factor(const Receiver& receiver, const Vec3* polygon, int n);

}  // namespace photometria
