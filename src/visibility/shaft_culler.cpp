// Shaft culling (Haines & Wallace 1994; visibility.h, 1.): the shaft of two polygons (or a point
// and a polygon) as its bounding box and the planes of its convex hull, and ShaftCuller's AABB
// tree over the occluders' bounding boxes (occluders.cpp merges the scene faces into them), which
// finds the occluders that may meet a shaft.
#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <utility>
#include <vector>

#include "visibility/visibility.h"
#include "visibility/visibility_internal.h"

namespace photometria {

using namespace visibility_detail;

namespace {

// The shaft of A and B (each a polygon or a point; A ∪ B at most kMaxShaftPoints points): its
// bounding box, and the planes of the convex hull of A ∪ B, built on first need (most queries are
// settled by bounding boxes alone). A hull face of two convex polygons contains either a whole
// polygon, or an edge of one and a vertex of the other, so these candidates are complete; a
// candidate is kept when every point lies on one closed side. For a non-convex B (a scene face
// used as a group of patches) the kept planes still each bound A ∪ B, so their intersection
// contains the hull: culling stays conservative.
class Shaft {
 public:
  Shaft(const Vec3* a, int na, const Vec3* b, int nb, double tol) : a_(a), b_(b), na_(na), nb_(nb), tol_(tol) {
    for (int k = 0; k < na; ++k) box_.extend(a[k]);
    for (int k = 0; k < nb; ++k) box_.extend(b[k]);
    box_.min().array() -= tol;
    box_.max().array() += tol;
  }
  const Eigen::AlignedBox3d& box() const { return box_; }
  bool has_planes() const { return have_planes_; }

  // True when occluder w (unit plane normal `normal`) cannot meet the open shaft: every corner of
  // A and B on one closed side of its plane (no open segment crosses it; this leaves out the
  // occluders A and B lie in and those they only touch), or w wholly on the outer side of one
  // hull plane.
  bool misses(const Polygon& w, const Vec3& normal) {
    bool below = true, above = true;
    for (int k = 0; k < na_ + nb_; ++k) {
      const double s = normal.dot((k < na_ ? a_[k] : b_[k - na_]) - w[0]);
      below = below && s <= tol_;
      above = above && s >= -tol_;
    }
    if (below || above) return true;
    if (!have_planes_) build_planes();
    for (int i = 0; i < plane_count_; ++i) {
      const Plane& p = planes_[i];
      bool outside = true;
      for (const Vec3& v : w)
        if (!(p.m.dot(v) - p.d >= -tol_)) {
          outside = false;
          break;
        }
      if (outside) return true;
    }
    return false;
  }

  // True when box b lies wholly on the outer side of one hull plane (within the tolerance, as
  // misses() counts a polygon's corners): no occluder inside it can meet the shaft, and misses()
  // would leave out each of them. Builds the hull's planes on first need.
  bool box_outside(const Eigen::AlignedBox3d& b) {
    if (!have_planes_) build_planes();
    for (int i = 0; i < plane_count_; ++i) {
      const Plane& p = planes_[i];
      // The box's corner least outside the plane.
      const Vec3 c(p.m.x() >= 0 ? b.min().x() : b.max().x(), p.m.y() >= 0 ? b.min().y() : b.max().y(),
                   p.m.z() >= 0 ? b.min().z() : b.max().z());
      if (p.m.dot(c) - p.d >= -tol_) return true;
    }
    return false;
  }

 private:
  // A point and a convex polygon it does not lie in the plane of (the gathers' and the centroid
  // rule's shafts): the hull is a pyramid whose planes are known, one per base edge through the
  // apex plus the base, so no candidate needs checking against every point.
  bool build_pyramid_planes() {
    if (na_ != 1 || nb_ < 3 || nb_ > 4) return false;
    const Vec3& x = a_[0];
    const Vec3 nb = newell_vector(b_, nb_);
    const double nlen = nb.norm();
    if (!(nlen > 0.0)) return false;
    const Vec3 n = nb / nlen;
    const double h = n.dot(x - b_[0]);
    if (!(std::abs(h) > tol_)) return false;  // apex (nearly) in the base plane
    Vec3 centre = Vec3::Zero();
    for (int k = 0; k < nb_; ++k) {
      const Vec3 turn = (b_[(k + 1) % nb_] - b_[k]).cross(b_[(k + 2) % nb_] - b_[(k + 1) % nb_]);
      if (!(turn.dot(n) > 0.0)) return false;  // not strictly convex: the general hull
      centre += b_[k] / nb_;
    }
    for (int k = 0; k < nb_; ++k) {
      Vec3 m = (b_[k] - x).cross(b_[(k + 1) % nb_] - x);
      const double len = m.norm();
      if (!(len > 0.0)) return false;
      m /= len;
      if (m.dot(centre - x) > 0.0) m = -m;  // pointing out of the pyramid
      planes_[plane_count_++] = {m, m.dot(x)};
    }
    const Vec3 out = h > 0.0 ? Vec3(-n) : n;  // beyond the base, away from the apex
    planes_[plane_count_++] = {out, out.dot(b_[0])};
    return true;
  }

  // Two axis-aligned boxes (box_corners' order): the planes of Haines & Wallace's box-to-box
  // shaft ("Shaft Culling for Efficient Ray-Cast Radiosity", Eurographics Workshop on Rendering
  // 1991; Photorealistic Rendering in Computer Graphics, Springer 1994). On each axis one box or
  // the other reaches the union box's lower face, and its upper one; for two faces of the union
  // box on different axes i and j reached by different boxes, the plane parallel to the third
  // axis through the edge of each box at those faces bounds both (their extents on i and j lie on
  // its inner side). With the union box these planes bound the hull of the two boxes.
  bool build_box_planes() {
    Eigen::AlignedBox3d a, b;
    if (!is_box(a_, na_, a) || !is_box(b_, nb_, b)) return false;
    for (int i = 0; i < 3; ++i)
      for (int j = i + 1; j < 3; ++j)
        for (int side_i = 0; side_i < 2; ++side_i)
          for (int side_j = 0; side_j < 2; ++side_j) {
            // The boxes' reach on each side: the upper face when side is 1, the lower when 0.
            const double ai = side_i ? a.max()[i] : a.min()[i], bi = side_i ? b.max()[i] : b.min()[i];
            const double aj = side_j ? a.max()[j] : a.min()[j], bj = side_j ? b.max()[j] : b.min()[j];
            const double si = side_i ? 1.0 : -1.0, sj = side_j ? 1.0 : -1.0;
            const bool a_reaches_i = si * (ai - bi) > tol_, b_reaches_i = si * (bi - ai) > tol_;
            const bool a_reaches_j = sj * (aj - bj) > tol_, b_reaches_j = sj * (bj - aj) > tol_;
            if (!((a_reaches_i && b_reaches_j) || (b_reaches_i && a_reaches_j))) continue;
            // The line through (ai, aj) and (bi, bj) in the (i, j) plane, its normal turned toward
            // the union box's edge on these sides.
            Vec3 m = Vec3::Zero();
            m[i] = bj - aj;
            m[j] = ai - bi;
            if (m[i] * si + m[j] * sj < 0.0) m = -m;
            const double len = m.norm();
            if (!(len > 0.0)) continue;
            m /= len;
            Vec3 on = Vec3::Zero();
            on[i] = ai;
            on[j] = aj;
            planes_[plane_count_++] = {m, m.dot(on)};
          }
    return true;
  }

  // Whether the n points are the 8 corners of their bounding box in box_corners' order (into box).
  static bool is_box(const Vec3* p, int n, Eigen::AlignedBox3d& box) {
    if (n != 8) return false;
    for (int k = 0; k < 8; ++k) box.extend(p[k]);
    Vec3 corners[8];
    box_corners(box, corners);
    return std::equal(corners, corners + 8, p);
  }

  void build_planes() {
    have_planes_ = true;
    if (build_pyramid_planes() || build_box_planes()) return;
    plane_count_ = 0;
    Vec3 pts[kMaxShaftPoints];
    int np = 0;
    for (int k = 0; k < na_; ++k) pts[np++] = a_[k];
    for (int k = 0; k < nb_; ++k) pts[np++] = b_[k];
    auto try_plane = [&](Vec3 m, const Vec3& p0) {
      const double len = m.norm();
      if (!(len > 0.0) || plane_count_ == kMaxPlanes) return;
      // Sides tested before normalising (the tolerance scaled instead), and given up at the first
      // point on each side: most candidates are not hull planes, and show it within a few points.
      const double d = m.dot(p0), tol = tol_ * len;
      bool below = true, above = true;
      for (int k = 0; k < np && (below || above); ++k) {
        const double s = m.dot(pts[k]) - d;
        below = below && s <= tol;
        above = above && s >= -tol;
      }
      if (!below && !above) return;
      m /= len;
      if (below) planes_[plane_count_++] = {m, d / len};
      else planes_[plane_count_++] = {-m, -d / len};
    };
    auto edges_with_vertices = [&](const Vec3* p, int n, const Vec3* q, int nq) {
      if (n < 2) return;
      for (int e = 0; e < n; ++e) {
        const Vec3& e0 = p[e];
        const Vec3& e1 = p[(e + 1) % n];
        for (int v = 0; v < nq; ++v) try_plane((e1 - e0).cross(q[v] - e0), e0);
      }
    };
    edges_with_vertices(a_, na_, b_, nb_);
    edges_with_vertices(b_, nb_, a_, na_);
    if (na_ >= 3) try_plane(newell_vector(a_, na_), a_[0]);
    if (nb_ >= 3) try_plane(newell_vector(b_, nb_), b_[0]);
  }

  // Enough for every candidate of a quad against a 20-corner group (2·4·20 + 2); dropping a
  // plane beyond it would only cull less.
  static constexpr int kMaxPlanes = 2 * 4 * (kMaxShaftPoints - 4) + 2;
  const Vec3 *a_, *b_;
  int na_, nb_;
  double tol_;
  Eigen::AlignedBox3d box_;
  bool have_planes_ = false;
  int plane_count_ = 0;
  Plane planes_[kMaxPlanes];
};

}  // namespace

void box_corners(const Eigen::AlignedBox3d& box, Vec3 corners[8]) {
  const Vec3 lo = box.min(), hi = box.max();
  const int loop[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 1, 1}, {1, 1, 1}, {1, 0, 1}, {0, 0, 1}};
  for (int k = 0; k < 8; ++k)
    corners[k] = Vec3(loop[k][0] ? hi.x() : lo.x(), loop[k][1] ? hi.y() : lo.y(), loop[k][2] ? hi.z() : lo.z());
}

ShaftCuller::ShaftCuller(const Scene& scene) {
  tol_ = 1e-9 * std::max(bounding_diagonal(scene.vertices), 1e-30);
  const int faces = static_cast<int>(scene.faces.size());
  scene_faces_.reserve(size_t(faces));
  for (int f = 0; f < faces; ++f) scene_faces_.push_back(scene.face_polygon(f));
  MergedOccluders merged = merge_coplanar_faces(scene, tol_);
  const int n = static_cast<int>(merged.faces.size());
  occluder_of_face_.assign(size_t(faces), -1);
  occluders_.reserve(size_t(n));
  for (int o = 0; o < n; ++o) {
    const std::vector<int>& of = merged.faces[size_t(o)];
    if (of.size() == 1) {
      occluders_.push_back(scene_faces_[size_t(of[0])]);  // a face joined to none: itself, unchanged
    } else {
      Polygon p;
      for (int v : merged.corners[size_t(o)]) p.push_back(scene.vertices[size_t(v)]);
      occluders_.push_back(std::move(p));
    }
    for (int f : of) occluder_of_face_[size_t(f)] = o;
    normals_.push_back(polygon_normal(occluders_.back()));
    Eigen::AlignedBox3d box;
    for (const Vec3& v : occluders_.back()) box.extend(v);
    boxes_.push_back(box);
  }
  occluder_faces_ = std::move(merged.faces);
  occluder_corners_ = std::move(merged.corners);
  order_.resize(size_t(n));
  std::iota(order_.begin(), order_.end(), 0);
  if (n > 0) {
    nodes_.reserve(2 * n);
    build(0, n);
  }
  find_convex_solids();
}

// Median split on the longest axis of the box centres; leaves hold up to 4 occluders.
int ShaftCuller::build(int first, int count) {
  const int id = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
  Eigen::AlignedBox3d box, centres;
  for (int k = first; k < first + count; ++k) {
    box.extend(boxes_[order_[k]]);
    centres.extend(boxes_[order_[k]].center());
  }
  nodes_[id].box = box;
  if (count <= 4) {
    nodes_[id].first = first;
    nodes_[id].count = count;
    return id;
  }
  int axis = 0;
  centres.sizes().maxCoeff(&axis);
  const int half = count / 2;
  std::nth_element(order_.begin() + first, order_.begin() + first + half, order_.begin() + first + count,
                   [&](int x, int y) { return boxes_[x].center()[axis] < boxes_[y].center()[axis]; });
  const int left = build(first, half);
  const int right = build(first + half, count - half);
  nodes_[id].left = left;
  nodes_[id].right = right;
  return id;
}

void ShaftCuller::occluders(const Vec3* a, int na, const Vec3* b, int nb, std::vector<int>& out, bool drop_hidden,
                            int on_face) const {
  out.clear();
  if (nodes_.empty()) return;
  if (na + nb > kMaxShaftPoints) throw std::invalid_argument("ShaftCuller: a shaft of more than 24 points");
  if (drop_hidden && na != 1) throw std::invalid_argument("ShaftCuller: drop_hidden needs a point receiver");
  Shaft shaft(a, na, b, nb, tol_);
  // drop_hidden: the occluders the point is clearly behind, of convex solids it is clearly
  // outside of, are skipped before the costlier shaft tests (drop_hidden_occluders() during the
  // search).
  thread_local std::vector<signed char> outside_state;
  thread_local std::vector<int> touched;
  if (drop_hidden) outside_state.resize(solids_.size() + closed_solids_.size(), 0);
  auto hidden = [&](int f) { return hidden_from(a[0], f, on_face, nullptr, outside_state, touched); };
  int stack[128];
  int top = 0;
  stack[top++] = 0;
  // A point's shaft is a pyramid whose few planes cost little to build: its planes prune whole
  // subtrees that its bounding box alone does not (a thin shaft across the room to a small face).
  // Other shafts prune so once a candidate has needed their planes.
  const bool prune_by_planes = na == 1;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (!boxes_meet(node.box, shaft.box())) continue;
    if ((prune_by_planes || shaft.has_planes()) && shaft.box_outside(node.box)) continue;
    if (node.left < 0) {
      for (int k = node.first; k < node.first + node.count; ++k) {
        const int f = order_[k];
        if (boxes_meet(boxes_[f], shaft.box()) && !(drop_hidden && hidden(f)) &&
            !shaft.misses(occluders_[f], normals_[f]))
          out.push_back(f);
      }
    } else {
      stack[top++] = node.left;
      stack[top++] = node.right;
    }
  }
  if (drop_hidden) {
    for (int solid : touched) outside_state[size_t(solid)] = 0;
    touched.clear();
  }
  std::sort(out.begin(), out.end());  // a fixed order: results do not depend on the traversal
}

void ShaftCuller::occluders_among(const Vec3* a, int na, const Vec3* b, int nb, const std::vector<int>& candidates,
                                  std::vector<int>& out) const {
  out.clear();
  if (candidates.empty()) return;
  if (na + nb > kMaxShaftPoints) throw std::invalid_argument("ShaftCuller: a shaft of more than 24 points");
  Shaft shaft(a, na, b, nb, tol_);
  for (int f : candidates)
    if (boxes_meet(boxes_[f], shaft.box()) && !shaft.misses(occluders_[f], normals_[f])) out.push_back(f);
}

}  // namespace photometria

namespace photometria {

bool ShaftCuller::blocks_every_segment(const Vec3* a, int na, const Vec3* b, int nb, int o) const {
  const Polygon& w = occluders_[size_t(o)];
  const Vec3& n = normals_[size_t(o)];
  // A and B strictly on opposite sides of W's plane (by more than the tolerance).
  double a_lo = 1e300, a_hi = -1e300, b_lo = 1e300, b_hi = -1e300;
  for (int k = 0; k < na; ++k) {
    const double s = n.dot(a[k] - w[0]);
    a_lo = std::min(a_lo, s);
    a_hi = std::max(a_hi, s);
  }
  for (int k = 0; k < nb; ++k) {
    const double s = n.dot(b[k] - w[0]);
    b_lo = std::min(b_lo, s);
    b_hi = std::max(b_hi, s);
  }
  const bool a_above = a_lo > tol_ && b_hi < -tol_, a_below = a_hi < -tol_ && b_lo > tol_;
  if (!a_above && !a_below) return false;
  // The segments' crossings of W's plane fill the section of hull(A ∪ B) by the plane, the convex
  // hull of the corner-to-corner crossings: every segment crosses inside W when those all do
  // (clearly inside, by the tolerance: a segment through W's boundary is not blocked).
  for (int i = 0; i < na; ++i) {
    const double sa = n.dot(a[i] - w[0]);
    for (int j = 0; j < nb; ++j) {
      const double sb = n.dot(b[j] - w[0]);
      const Vec3 p = a[i] + (sa / (sa - sb)) * (b[j] - a[i]);
      for (size_t k = 0; k < w.size(); ++k) {
        const Vec3& e0 = w[k];
        const Vec3& e1 = w[k + 1 == w.size() ? 0 : k + 1];
        const Vec3 edge = e1 - e0;
        // n · (edge × (p − e0)) / |edge|: p's distance inside the edge's line (W counter-clockwise about n).
        if (n.dot(edge.cross(p - e0)) <= tol_ * edge.norm()) return false;
      }
    }
  }
  return true;
}

}  // namespace photometria
