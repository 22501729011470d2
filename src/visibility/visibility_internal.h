// Pieces the visibility files share (visibility.h is the public interface; one .cpp per job):
//   rays.cpp             ray casting with Embree 3 (RayVisibility, pair_stream)
//   occluders.cpp        occluders: coplanar scene faces merged into convex polygons
//                        (merge_coplanar_faces)
//   shaft_culler.cpp     the shaft test and the AABB tree of occluders (ShaftCuller)
//   convex_solids.cpp    convex solids among the occluders, and convex enclosures
//                        (ShaftCuller::find_convex_solids / drop_hidden_occluders,
//                        scene_needs_no_visibility)
//   tiles.cpp            tiles of a mesh's patches and their shafts (GroupedShaftCuller)
//   shadow_clipping.cpp  exact visibility: polygons clipped against shadow volumes
//                        (shadow_clipping.h, exact_visible_form_factor)
//   point_visibility.cpp visible factors from one point to a mesh's patches (PointVisibility,
//                        Visibility)
// Lengths are metres, in the scene's coordinates unless said otherwise.
#pragma once

#include <Eigen/Geometry>
#include <vector>

#include "visibility/visibility.h"

namespace photometria::visibility_detail {

// ShaftCuller's occluders (visibility.h): scene faces merged into convex polygons, in the order
// of their first faces (with nothing to merge, occluder f is face f).
struct MergedOccluders {
  std::vector<std::vector<int>> faces;    // per occluder: its scene faces, ascending
  std::vector<std::vector<int>> corners;  // per occluder: its corners, counter-clockwise, as scene
                                          // vertex indices
};
// Coplanar scene faces (unit normals within 1e-9 rad, plane offsets within tol, metres) of one
// orientation that share edges (the same two scene vertices: load_scene welds corners within
// about tol) are merged into their union where it is
// one convex polygon without holes (one boundary loop, convex once collinear corners are
// removed, of the faces' summed area within 1e-9 relative); a group whose union is not convex
// is split into convex pieces by merging neighbouring pieces while their union is convex. The
// occluders cover exactly the points the faces cover.
MergedOccluders merge_coplanar_faces(const Scene& scene, double tol);

// Eigen's AlignedBox::intersects, inlined: it is called tens of millions of times per fill.
inline bool boxes_meet(const Eigen::AlignedBox3d& a, const Eigen::AlignedBox3d& b) {
  return a.min().x() <= b.max().x() && b.min().x() <= a.max().x() && a.min().y() <= b.max().y() &&
         b.min().y() <= a.max().y() && a.min().z() <= b.max().z() && b.min().z() <= a.max().z();
}

// The diagonal of the bounding box of `v` (0 for none), metres: the scale of tolerances.
inline double bounding_diagonal(const std::vector<Vec3>& v) {
  if (v.empty()) return 0.0;
  Vec3 lo = v[0], hi = v[0];
  for (const Vec3& x : v) {
    lo = lo.cwiseMin(x);
    hi = hi.cwiseMax(x);
  }
  return (hi - lo).norm();
}

// A plane of a shaft or a shadow volume: m·y = d with unit normal m. Shafts keep m·y <= d
// (m pointing out); shadow volumes and clip_to_planes keep m·y >= d (m pointing in), in
// coordinates relative to the receiver point.
struct Plane {
  Vec3 m;    // unit normal, pointing out of the shaft
  double d;  // the plane is m·y = d; the shaft lies in m·y <= d
};

// The most points a shaft's two ends may have together (ShaftCuller::occluders,
// GroupedShaftCuller's face level; shaft_culler.cpp sizes its plane store by it).
constexpr int kMaxShaftPoints = 24;

}  // namespace photometria::visibility_detail
