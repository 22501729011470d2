// The part of a polygon a receiver point can see, in coordinates relative to the receiver: the
// common first step of every exact point-to-polygon kernel (lambert, iwanicki, stark-vertex,
// stark-image; see kernels.h).
//
// Conventions (docs/theory.md "Units and conventions"; docs/usage.md `photometria formfactor`):
//  - one-sided: a receiver behind the polygon's plane (Newell normal pointing away) sees nothing;
//  - only the part above the receiver's tangent plane counts: the polygon is clipped to the
//    closed half-space N·x >= 0 (Sutherland–Hodgman; Heitz 2017 sec. 1 assumes a clipped polygon);
//  - a receiver in the polygon's plane sees zero solid angle, except on its boundary (an edge or
//    a vertex) where the limit as p is approached along `Receiver::approach` is taken: a vertex
//    at p is replaced by the direction −u (only directions from p matter to the kernels).
#pragma once

#include "kernels/lambert.h"

namespace photometria {

// Result of visible_polygon(). `a` holds the visible polygon's vertices relative to the receiver
// point (a_i = v_i − p, metres; or unit directions for boundary limits), counter-clockwise seen
// from the polygon's front, every a_i with N·a_i >= 0 up to rounding.
struct VisiblePolygon {
  Polygon a;
  // True when `a` is the input polygon unchanged (a_i = v_i − p, same order, nothing clipped and
  // no boundary limit taken): kernels may then form differences v_i − v_0 from the input
  // coordinates, which keeps digits for a small polygon far from the receiver.
  bool whole = false;
};

// Fills `out`; returns false when the receiver sees nothing (F = 0): fewer than 3 vertices, a
// degenerate polygon, a receiver behind it, in its plane off its boundary, or everything below
// the horizon. `polygon` has n vertices (see lambert.h for orientation).
bool visible_polygon(const Receiver& receiver, const Vec3* polygon, int n, VisiblePolygon& out);

// The common case in one pass on the stack, for kernels that call it before visible_polygon():
// a polygon of at most kWholeMaxVertices vertices, wholly above the receiver's horizon (nothing to
// clip), with the receiver clearly in front of its plane or clearly behind it. Then returns true
// with `sum` = edge_angle_sum() of the relative polygon (0 when seen from behind), the same value
// the general path computes (same decisions, same operations); otherwise returns false and the
// caller takes the general path (boundary limits, clipping, degenerate polygons, long polygons).
// With far_factor > 0 it also returns false for a far polygon, far_factor·max|v_i − v_0|² <=
// |v_0 − p|², which the caller evaluates in a form of its own (iwanicki's centred sum).
constexpr int kWholeMaxVertices = 8;
bool whole_polygon_edge_sum(const Receiver& receiver, const Vec3* polygon, int n, double& sum, double far_factor = 0.0);

// Σ_i Θ_i N·(a_i × a_{i+1}) / |a_i × a_{i+1}|,  Θ_i = atan2(|a_i × a_{i+1}|, a_i · a_{i+1}),
// over the closed polygon `a` (vertices relative to the receiver): the edge sum of Lambert's
// formula (Heitz 2017 eq. 1, Stark 2000 eq. 3; references in lambert.h), equal to Iwanicki's
// Σ (Ω_i / sin Ω_i)(p_i × p_j)·N for unnormalized vectors (Iwanicki, final formula; iwanicki.h);
// F = −sum / 2π. Edge normals are formed on the shorter of a_i, a_{i+1}; a zero-length edge or
// an edge along a view ray adds nothing.
double edge_angle_sum(const Polygon& a, const Vec3& N);

}  // namespace photometria
