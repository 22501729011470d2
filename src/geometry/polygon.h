// Planar polygons in 3-D: normals, areas, centroids, half-space clipping, triangulation.
//
// A polygon is an ordered list of vertices (counter-clockwise seen from its front side, so that
// the right-hand (Newell) normal points to the front). Coordinates are in metres.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <vector>

namespace photometria {

using Vec3 = Eigen::Vector3d;
using Polygon = std::vector<Vec3>;

// Newell's normal: twice the vector area of the polygon (length = 2 * area for a planar polygon).
// Robust for non-convex and slightly non-planar polygons (Newell, see Sutherland et al. 1974).
Vec3 newell_vector(const Vec3* v, int n);
inline Vec3 newell_vector(const Polygon& p) { return newell_vector(p.data(), static_cast<int>(p.size())); }

// Unit normal (zero vector if the polygon is degenerate).
Vec3 polygon_normal(const Polygon& p);

// Area of a planar polygon: |Newell vector| / 2.
double polygon_area(const Polygon& p);

// Area-weighted centroid of a planar polygon (fan of triangles from vertex 0).
Vec3 polygon_centroid(const Polygon& p);

// Largest distance of a vertex from the polygon's best plane (through the vertex mean, with the
// Newell normal): 0 for a planar polygon.
double planarity_deviation(const Polygon& p);

// Sutherland–Hodgman clip of `in` to the closed half-space {x : n·(x - origin) >= 0}.
// Vertices exactly on the plane are kept; crossing edges get a new vertex on the plane.
// Works on vectors relative to `origin` to keep digits when the polygon is far away.
void clip_to_halfspace(const Vec3* in, int n, const Vec3& plane_normal, Polygon& out);

// The same for the plane through `origin`: `out` = the part of v[0..n) on the closed side
// {x : normal·(x − origin) >= 0}, in absolute coordinates.
void clip_to_halfspace_at(const Vec3* v, int n, const Vec3& origin, const Vec3& normal, Polygon& out);

// Splits a simple (possibly non-convex) polygon into triangles by ear clipping in its own
// plane. Returns index triples into the polygon. Degenerate polygons give no triangles.
std::vector<std::array<int, 3>> triangulate_polygon(const Polygon& p);

// True if the planar polygon is strictly convex (all turns have the sign of the normal).
bool is_convex(const Polygon& p);

}  // namespace photometria
