// Exact visibility by clipping (Nishita & Nakamae 1985, in 3-D; visibility.h, 3.): convex
// polygons, relative to the receiver point x, are cut by the shadow volumes of occluders seen
// from x into visible and hidden pieces. Used by exact_visible_form_factor (shadow_clipping.cpp)
// for one source patch and by PointVisibility (point_visibility.cpp) for a whole tile.
//
// Shapes and units: polygons are Polygon (std::vector<Vec3>), convex, metres relative to x; a
// shadow volume is the set of points inside every one of its planes (m·y >= d, unit m, d in
// metres relative to x).
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "visibility/visibility.h"
#include "visibility/visibility_internal.h"

namespace photometria::visibility_detail {

// A list of polygons that keeps its polygons' storage between uses (clear() forgets the count only).
class PiecePool {
 public:
  void clear() { size_ = 0; }
  size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  Polygon& operator[](size_t i) { return store_[i]; }
  const Polygon& operator[](size_t i) const { return store_[i]; }
  Polygon& push() {
    if (size_ == store_.size()) store_.emplace_back();
    return store_[size_++];
  }
  void truncate(size_t n) { size_ = std::min(size_, n); }  // forgets the polygons from n on
  friend void swap(PiecePool& a, PiecePool& b) noexcept {
    a.store_.swap(b.store_);
    std::swap(a.size_, b.size_);
  }

 private:
  std::vector<Polygon> store_;
  size_t size_ = 0;
};

// The shadow volume of convex solid `solid` of `culler` seen from x, relative to x (m·y >= d
// inside), when x is clearly outside it (false otherwise: then its faces cast their shadows one
// by one). A segment from x meets the solid exactly when it crosses the cone from x through the
// solid's silhouette (the edges between a face x is in front of and one it is not), and beyond
// the entry point it is behind every front face's plane; so the shadow is one convex volume: a
// wedge plane per silhouette edge and the plane of each front face (Crow 1977, "Shadow
// algorithms for computer graphics": a shadow volume bounded by planes through the light and
// the occluder's silhouette edges; here the "light" is the receiver point, as in Nishita &
// Nakamae 1985). One volume instead of one per front face (three for a box) cuts the pieces
// fewer times. reach: the largest distance from x to the solid's corners (its classification
// tolerance is 1e-12 × the configuration's size, which includes it).
bool solid_volume(const ShaftCuller& culler, int solid, const Vec3& x, std::vector<Plane>& volume, double& reach);

// The shadow volumes cast from one point x: of single faces and of convex solids, each built on
// first use and kept until the next point. A point's tiles share most of their occluders, so a
// volume is built once per point rather than once per tile and occluder.
class ShadowVolumes {
 public:
  struct Volume {
    long long stamp = -1;
    bool casts = false;         // false: no volume (a face seen edge-on, a solid x is not outside)
    double reach = 0.0;         // largest distance from x to the occluder's corners
    double edge_on = 0.0;       // a face: the distance of its plane from x (it blocks nothing when <= eps)
    std::vector<Plane> planes;  // m·y >= d inside the shadow, relative to x
  };

  // Forgets every volume: the following ones are seen from x.
  void start(const Vec3& x) {
    x_ = x;
    ++generation_;
  }

  // The squared distance from x to face f's nearest corner (the order of subtraction).
  double nearest(const std::vector<Polygon>& faces, int f) {
    if (size_t(f) >= nearest_.size()) nearest_.resize(faces.size(), {-1, 0.0});
    auto& [stamp, d] = nearest_[size_t(f)];
    if (stamp != generation_) {
      stamp = generation_;
      d = std::numeric_limits<double>::infinity();
      for (const Vec3& v : faces[size_t(f)]) d = std::min(d, (v - x_).squaredNorm());
    }
    return d;
  }

  // Face f's own shadow volume: beyond its plane, inside the cone from x through its edges.
  const Volume& face(const std::vector<Polygon>& faces, const std::vector<Vec3>* normals, int f) {
    if (size_t(f) >= faces_.size()) faces_.resize(faces.size());
    Volume& v = faces_[size_t(f)];
    if (v.stamp == generation_) return v;
    v.stamp = generation_;
    v.planes.clear();
    const Polygon& w = faces[size_t(f)];
    const int wn = static_cast<int>(w.size());
    Polygon& wr = relative_;
    wr.resize(size_t(wn));
    Vec3 centre = Vec3::Zero();
    v.reach = 0.0;
    for (int k = 0; k < wn; ++k) {
      wr[size_t(k)] = w[size_t(k)] - x_;
      centre += wr[size_t(k)] / wn;
      v.reach = std::max(v.reach, wr[size_t(k)].norm());
    }
    const Vec3 nw = normals ? (*normals)[size_t(f)] : polygon_normal(w);
    const double h = nw.dot(wr[0]);  // signed distance of W's plane from x along nw
    v.casts = !nw.isZero();
    v.edge_on = std::abs(h);
    if (!v.casts) return v;
    // Beyond W's plane, on the side away from x.
    v.planes.push_back({h > 0 ? nw : Vec3(-nw), std::abs(h)});
    // Inside the cone from x through W: one wedge plane through x per edge, oriented to W.
    for (int k = 0; k < wn; ++k) {
      Vec3 m = wr[size_t(k)].cross(wr[size_t((k + 1) % wn)]);
      const double len = m.norm();
      if (!(len > 0.0)) continue;
      m /= len;
      if (m.dot(centre) < 0) m = -m;
      v.planes.push_back({m, 0.0});
    }
    return v;
  }

  // Convex solid s's one shadow volume (solid_volume).
  const Volume& solid(const ShaftCuller& culler, int s) {
    if (size_t(s) >= solids_.size()) solids_.resize(size_t(culler.convex_solid_count()));
    Volume& v = solids_[size_t(s)];
    if (v.stamp == generation_) return v;
    v.stamp = generation_;
    v.planes.clear();
    v.casts = solid_volume(culler, s, x_, v.planes, v.reach);
    return v;
  }

 private:
  Vec3 x_ = Vec3::Zero();
  long long generation_ = 0;
  std::vector<std::pair<long long, double>> nearest_;
  std::vector<Volume> faces_, solids_;
  Polygon relative_;  // scratch of face(): its corners relative to x
};

// Subtracts from `pieces` (convex polygons relative to x, at most `scale` from it) the shadow
// volumes of faces[which] (occluders, convex: ShaftCuller::occluder_polygons) seen from x: what
// is left is the part of them x sees. `shadows`
// (optional) receives the hidden parts; they are disjoint, and with what is left they partition
// the input. Returns true when any face cut or hid a piece (false: the pieces are unchanged).
// With `solids` (the culler whose occluders these are), the listed ones of a convex solid that x is
// clearly outside of are replaced by the solid's one shadow volume (see solid_volume).
// `volumes`: the shadow volumes seen from x (started at x), reused across calls from one point.
bool subtract_shadows(double scale, const std::vector<Polygon>& faces, const std::vector<int>& which,
                      const std::vector<Vec3>* normals, PiecePool& pieces, PiecePool* shadows,
                      const ShaftCuller* solids, ShadowVolumes& volumes);

}  // namespace photometria::visibility_detail
