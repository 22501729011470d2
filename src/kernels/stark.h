// Stark's vertex-based formulations of the point-to-polygon form factor (M. M. Stark,
// "Vertex-Based Formulations of Irradiance from Polygonal Sources", University of Utah tech.
// report UUCS-00-012, 2000; equation numbers below are the report's). Both are
// sums over the vertices of the visible (clipped) polygon, equal to Lambert's edge sum; same
// conventions and domain as lambert_form_factor() (see visible_polygon.h). Results in [0, 1].
//
// Why they need care: as printed, every vertex term is an O(1) angle (measured from the edge
// direction, eq. 11, or from the edge's acme, eq. 45) times an O(1) cosine, whatever the size
// of F. For a polygon 1e6 sizes away (F ~ 1e-13) the terms cancel over 13 orders of magnitude
// and the plain sums kept ~4 digits (stark-vertex 2e-4, stark-image 1.5e-5 relative). Two exact
// rewritings remove that, one per source of cancellation; neither changes the value:
//  1. Reference point. A vertex term only enters as the difference between the two ends of its
//     edge, so the angles may be measured from any reference in the edge's plane (Fig. 5a; the
//     per-edge constant cancels between the two ends, like the first term of eq. 9). For an edge
//     subtending at most 90° (a_j·a_{j+1} >= 0) the reference is the edge's midpoint
//     m_j = (a_j + a_{j+1})/2, whose direction is then accurate (|m_j| >= max|a|/2); each term is
//     then as small as the edge's own angle, formed by the arctangent subtraction formula. Wider
//     edges keep the printed reference (their angle is O(1) anyway, and a midpoint close to p
//     would have an inaccurate direction).
//  2. Centred evaluation (a polygon small against its distance, as iwanicki.h): with c = v_0 − p,
//     r_i = v_i − v_0 from the input coordinates (exact shape far away), w̄ = 1/|c|², a vertex
//     term is the vector ω (m_j × δ), δ = a_i − m_j = ∓e_j/2, ω = (angle)/|m_j × δ|
//     = (atan τ/τ)/(m_j·a_i), τ = tan(angle); its part w̄ c × δ sums to w̄ c × Σ_i(ρ_{i−1} − ρ_i) = 0
//     over the closed polygon (ρ_j = m_j − c) and is left out. The rest,
//     (ω − w̄) c × δ + ω ρ_j × δ, with ω − w̄ from a series of atan τ/τ − 1 and
//     m_j·a_i − |c|² = c·(ρ_j + r_i) + ρ_j·r_i, is of the order of F. Used when the input polygon
//     is seen whole (nothing clipped, no boundary limit) and every vertex lies within |c|/16 of v_0.
// Edge normals are formed as a × e on the shorter of a_j, a_{j+1} (a receiver close to a vertex
// keeps the digits of that vertex's direction).
//
// Accuracy (docs/kernels.md, tests/test_kernels_polygon.cpp, tests/test_kernels_stability.cpp):
// relative error ~ε·κ, κ the cancellation factor of the sum that is evaluated: κ = Σ|Θ_j N·n̂_j|/
// (2πF) of the visible polygon for the direct sums (the same as Lambert's; O(1) unless F is small
// for a geometric reason: a sliver of the polygon above the horizon, a polygon seen edge-on), and
// κ_C = (area/(π|c|²))/F ≈ 1/(cos θ_receiver · cos θ_polygon) for the centred sums — the
// conditioning of F itself, 1e-15 for a polygon 1e6 sizes away facing the receiver. Regimes
// where ε·κ exceeds ~1e-13 (and where every exact kernel, lambert and iwanicki included, is
// limited the same way): a polygon clipped by the horizon to a sliver of height h (κ ~ 1/h²),
// a polygon seen within an angle γ of edge-on or within γ of the receiver's horizon (κ ~ 1/γ),
// a far polygon that straddles the horizon (not centred: κ ~ distance/size).
#pragma once

#include "kernels/lambert.h"

namespace photometria {

// Vertex-based reformulation of Lambert's formula, Stark 2000 eqs. (12)–(13):
//   F = (1/2π) Σ_i [ ∠(a_i, e_{i−1}) N·n̂_{i−1} − ∠(a_i, e_i) N·n̂_i ],
//   e_i = v_{i+1} − v_i,  n̂_i = (a_i × e_i)/|a_i × e_i|,  ∠(a, e) = atan2(h, t)  (eq. 11),
// with h = |a × ê| (the distance of p from the edge's line, the same at both ends) and t = a·ê.
// Angles of edges subtending <= 90° measured from the edge's midpoint (Fig. 5a, rewriting 1
// above), by atan2(h (t_a − t_m), h² + t_a t_m); centred evaluation (rewriting 2) far away.
double stark_vertex_form_factor(const Receiver& receiver, const Vec3* polygon, int n);

// Image-plane formula, Stark 2000 eqs. (8)–(10), in its projective / homogeneous form
// (eqs. 43–46, Fig. 10–11). The visible polygon is projected through p onto the plane one unit
// above the receiver (eq. 4): vertex a ↦ homogeneous point (X, Y, W) = (u·a, w·a, N·a), W = 0 for
// a vertex on the receiver plane (a "vertex at infinity", sec. 6.4); an edge is the homogeneous
// line l ∝ a_i × a_{i+1} through its two vertices, whose projective direction is Stark's (a, b).
// Eq. (45)'s vertex term G(x, y; a, b) = C (a y − b x) atan(C (a x + b y)) then reads
//   G = −(N·n̂) atan u,  u = N·(a × n̂)/W,   n̂ = l/|l|
// (C(a y − b x) = −N·n̂ is the cosine of eq. 29/32, u = C(a x + b y) the tangent of the angle
// from the edge's acme, eqs. 25/37), and F = (1/2π) Σ_i [G(v_i; edge i−1) − G(v_i; edge i)]
// (eq. 44). Evaluated with the 3-D representative of each homogeneous point (no division by W:
// nothing is lost for vertices close to the horizon), per edge:
//  - an edge subtending <= 90°: measured from the homogeneous midpoint m = a_i + a_{i+1} by the
//    arctangent subtraction formula, atan u − atan u_m = atan2(u − u_m, 1 + u u_m), multiplied
//    through by W W_m >= 0; at W = 0 it gives Fig. 11's "vertex at infinity" ±π/2 terms;
//  - a wider edge: atan2(N·(a × n̂), W), eq. (45) as printed;
//  - an edge at infinity (both ends on the receiver plane), and an edge whose image line lies
//    farther than √3 from the image origin (|N·n̂| > √3/2, where the acme tangents are
//    ill-conditioned): the angle in the edge's own plane, as eq. (46) measures it — from the
//    edge vector, or from the midpoint for an edge subtending <= 90°;
//  - far away (rewriting 2 above), the same terms centred on c, with τ = tan(angle) from the
//    tangents of eq. (45): the line l_j = c × e_j + r_j × r_{j+1}, of which the part c × e_j sums
//    to zero. (In image-plane coordinates x = X/W the centring would leave terms ~1/(1 + |x|²)
//    times the result for a polygon near the horizon: homogeneous 3-vectors keep it isotropic.)
double stark_image_form_factor(const Receiver& receiver, const Vec3* polygon, int n);

}  // namespace photometria
