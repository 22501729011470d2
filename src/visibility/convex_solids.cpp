// Convexity among the scene's faces and occluders: a scene that is one convex enclosure needs no
// visibility at all (scene_needs_no_visibility, over the faces), and the convex solids among the
// occluders (closed, consistently oriented components of occluders, such as boxes, however
// finely their faces are meshed) cast their shadow through the occluders toward a point outside
// them only (ShaftCuller::drop_hidden_occluders; shadow_clipping.cpp builds their one shadow
// volume from the solids and occluder neighbours found here). Closed solids that are not convex
// (scanned objects) drop their back occluders too, for points found to be outside them.
#include <cmath>
#include <map>
#include <numeric>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "visibility/visibility.h"
#include "visibility/visibility_internal.h"

namespace photometria {

using visibility_detail::bounding_diagonal;

bool scene_needs_no_visibility(const Scene& scene, std::string* reason) {
  const double tol = 1e-9 * bounding_diagonal(scene.vertices);
  // The plane tested last: the next face in it needs no test of its own (a surface meshed into
  // many faces lists them one after another), which makes this linear, not quadratic, in such
  // scenes. Same plane: normals within 1e-12 and the face's first corner within tol / 1000 of it.
  Vec3 tested_normal = Vec3::Zero(), tested_point = Vec3::Zero();
  for (size_t f = 0; f < scene.faces.size(); ++f) {
    const Polygon poly = scene.face_polygon(static_cast<int>(f));
    const Vec3 n = polygon_normal(poly);
    if ((n - tested_normal).lpNorm<Eigen::Infinity>() <= 1e-12 &&
        std::abs(tested_normal.dot(poly[0] - tested_point)) <= 1e-3 * tol)
      continue;
    tested_normal = n;
    tested_point = poly[0];
    for (size_t v = 0; v < scene.vertices.size(); ++v) {
      if (n.dot(scene.vertices[v] - poly[0]) < -tol) {
        if (reason) {
          std::ostringstream s;
          s << "face " << scene.faces[f].source_face << " has vertex " << v
            << " behind its plane, so faces may block each other";
          *reason = s.str();
        }
        return false;
      }
    }
  }
  if (reason) *reason = "every vertex lies in front of every face: a convex enclosure, no face can block any pair";
  return true;
}

void ShaftCuller::find_convex_solids() {
  const int n = occluder_count();
  solid_of_.assign(size_t(n), -1);
  // Occluders joined by shared edges (vertex id pairs), union–find.
  std::vector<int> parent(static_cast<size_t>(n));
  std::iota(parent.begin(), parent.end(), 0);
  auto root = [&](int f) {
    while (parent[size_t(f)] != f) f = parent[size_t(f)] = parent[size_t(parent[size_t(f)])];
    return f;
  };
  std::map<std::pair<int, int>, std::vector<int>> edge_faces;  // directed edge -> occluders using it
  for (int f = 0; f < n; ++f) {
    const std::vector<int>& v = occluder_corners_[size_t(f)];
    for (size_t k = 0; k < v.size(); ++k) edge_faces[{v[k], v[(k + 1) % v.size()]}].push_back(f);
  }
  // The occluder across each edge (the one using its reverse), where there is exactly one.
  neighbours_.assign(size_t(n), {});
  for (int f = 0; f < n; ++f) {
    const std::vector<int>& v = occluder_corners_[size_t(f)];
    neighbours_[size_t(f)].assign(v.size(), -1);
    for (size_t k = 0; k < v.size(); ++k) {
      const auto twin = edge_faces.find({v[(k + 1) % v.size()], v[k]});
      if (twin != edge_faces.end() && twin->second.size() == 1) neighbours_[size_t(f)][k] = twin->second[0];
    }
  }
  closed_of_.assign(size_t(n), -1);
  std::vector<char> manifold(static_cast<size_t>(n), 1);
  for (const auto& [edge, faces] : edge_faces) {
    const auto twin = edge_faces.find({edge.second, edge.first});
    // Closed and consistently oriented: each directed edge once, its reverse once, in another occluder.
    if (faces.size() != 1 || twin == edge_faces.end() || twin->second.size() != 1 || twin->second[0] == faces[0]) {
      for (int f : faces) manifold[size_t(f)] = 0;
      continue;
    }
    const int a = root(faces[0]), b = root(twin->second[0]);
    if (a != b) parent[size_t(a)] = b;
  }
  std::map<int, std::vector<int>> components;
  for (int f = 0; f < n; ++f) components[root(f)].push_back(f);
  for (const auto& [r, faces] : components) {
    (void)r;
    bool eligible = faces.size() >= 4;
    for (int f : faces) eligible = eligible && manifold[size_t(f)] && !normals_[size_t(f)].isZero();
    // Convex with outward normals: every corner of the solid on or behind every occluder's plane.
    for (size_t i = 0; i < faces.size() && eligible; ++i)
      for (int g : faces)
        for (const Vec3& v : occluders_[size_t(g)])
          eligible = eligible && normals_[size_t(faces[i])].dot(v - occluders_[size_t(faces[i])][0]) <= tol_;
    if (eligible) {
      const int id = static_cast<int>(solids_.size());
      solids_.push_back(faces);
      for (int f : faces) solid_of_[size_t(f)] = id;
      continue;
    }
    // Not convex: a closed solid still, when closed and oriented outward (positive volume by the
    // divergence theorem, V = (1/3) Σ_faces (c_f · n_f) A_f; a closed room, whose normals point
    // inward, has negative volume and is left out).
    bool closed = faces.size() >= 4;
    for (int f : faces) closed = closed && manifold[size_t(f)] && !normals_[size_t(f)].isZero();
    if (!closed) continue;
    double volume = 0.0;
    Eigen::AlignedBox3d box;
    for (int f : faces) {
      const Polygon& w = occluders_[size_t(f)];
      volume += polygon_centroid(w).dot(normals_[size_t(f)]) * polygon_area(w) / 3.0;
      for (const Vec3& v : w) box.extend(v);
    }
    if (!(volume > tol_ * box.diagonal().squaredNorm())) continue;
    const int id = static_cast<int>(closed_solids_.size());
    closed_solids_.push_back(faces);
    closed_boxes_.push_back(box);
    for (int f : faces) closed_of_[size_t(f)] = id;
  }
  // One index per occluder for drop_hidden_occluders' states: convex solids, then the others.
  solid_state_of_.assign(size_t(n), -1);
  for (int f = 0; f < n; ++f)
    if (solid_of_[size_t(f)] >= 0) solid_state_of_[size_t(f)] = solid_of_[size_t(f)];
    else if (closed_of_[size_t(f)] >= 0)
      solid_state_of_[size_t(f)] = static_cast<int>(solids_.size()) + closed_of_[size_t(f)];
}

void ShaftCuller::touching_closed_solids(const Vec3& x, std::vector<int>& out) const {
  out.clear();
  if (closed_solids_.empty() || nodes_.empty()) return;
  const Vec3 margin = Vec3::Constant(tol_);
  const Eigen::AlignedBox3d at(x - margin, x + margin);
  int stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[size_t(stack[--top])];
    if (!node.box.intersects(at)) continue;
    if (node.left >= 0) {
      stack[top++] = node.left;
      stack[top++] = node.right;
      continue;
    }
    for (int k = node.first; k < node.first + node.count; ++k) {
      const int f = order_[size_t(k)];
      if (closed_of_[size_t(f)] < 0 || !boxes_[size_t(f)].intersects(at)) continue;
      const Polygon& w = occluders_[size_t(f)];
      const Vec3& n = normals_[size_t(f)];
      if (std::abs(n.dot(x - w[0])) > tol_) continue;
      bool inside = true;
      for (size_t e = 0; e < w.size() && inside; ++e) {
        const Vec3 edge = w[(e + 1) % w.size()] - w[e];
        inside = n.dot(edge.cross(x - w[e])) >= -tol_ * edge.norm();
      }
      if (inside) out.push_back(f);
    }
  }
}

bool ShaftCuller::outside_closed_solid(const Vec3& x, int solid, int on_face, const Vec3* normal) const {
  // On the solid's own surface, inside a face: a segment to a source in front of the face
  // starts into the outside.
  if (on_face >= 0 && closed_of_[size_t(occluder_of_face_[size_t(on_face)])] == solid) return true;
  const Eigen::AlignedBox3d& box = closed_boxes_[size_t(solid)];
  const Vec3 margin = Vec3::Constant(tol_);
  if (!Eigen::AlignedBox3d(box.min() - margin, box.max() + margin).contains(x)) return true;
  // On its surface (a vertex of a scanned object, a point where it touches the floor): a segment
  // may start into the solid there. Unless, with the receiver's normal, every face touching x lies
  // on or behind x's tangent plane and one of them faces along the normal: then no boundary
  // point lies just in front of the plane, and what lies there is outside (it borders that
  // face's front), so every segment toward the sources in front starts outside.
  thread_local std::vector<int> touching;
  touching_closed_solids(x, touching);
  bool touches = false, below = true, along = false;
  for (int f : touching) {
    if (closed_of_[size_t(f)] != solid) continue;
    if (!normal) return false;
    touches = true;
    for (const Vec3& c : occluders_[size_t(f)]) below = below && normal->dot(c - x) <= tol_;
    along = along || normal->dot(normals_[size_t(f)]) > 0.0;
  }
  if (touches) return below && along;
  // Parity of the crossings of a segment from x to beyond the box (Jordan's theorem for a closed
  // surface), along a direction no face of a modelled scene is likely to contain. Any crossing
  // within the tolerance of a face's plane at x, or of an edge, gives up: x is then not
  // clearly outside.
  const Vec3 direction = Vec3(0.3141592653, 0.8660254038, 0.3887261234).normalized();
  const double reach = (box.center() - x).norm() + box.diagonal().norm() + 1.0;
  const Vec3 far = x + reach * direction;
  thread_local std::vector<int> candidates;
  occluders(&x, 1, &far, 1, candidates);
  int crossings = 0;
  for (int f : candidates) {
    if (closed_of_[size_t(f)] != solid) continue;
    const Polygon& w = occluders_[size_t(f)];
    const Vec3& n = normals_[size_t(f)];
    const double s0 = n.dot(x - w[0]), s1 = n.dot(far - w[0]);
    if (std::abs(s0) <= tol_) return false;
    if ((s0 > 0) == (s1 > 0)) continue;
    const Vec3 p = x + (s0 / (s0 - s1)) * (far - x);
    bool inside = true;
    for (size_t k = 0; k < w.size(); ++k) {
      const Vec3 edge = w[(k + 1) % w.size()] - w[k];
      const double d = n.dot(edge.cross(p - w[k]));  // p's distance inside the edge's line × |edge|
      if (std::abs(d) <= tol_ * edge.norm()) return false;
      inside = inside && d > 0;
    }
    crossings += inside;
  }
  return crossings % 2 == 0;
}

bool ShaftCuller::hidden_from(const Vec3& x, int f, int on_face, const Vec3* normal,
                              std::vector<signed char>& outside_state, std::vector<int>& touched) const {
  const int index = solid_state_of_[size_t(f)];
  // Signed distance of x in front of occluder g's plane.
  auto height = [&](int g) { return normals_[size_t(g)].dot(x - occluders_[size_t(g)][0]); };
  if (index < 0 || !(height(f) < -tol_)) return false;
  signed char& state = outside_state[size_t(index)];
  if (state == 0) {
    const int convex_count = static_cast<int>(solids_.size());
    bool outside = false;
    if (index < convex_count)
      for (int g : solids_[size_t(index)]) outside = outside || height(g) > tol_;
    else outside = outside_closed_solid(x, index - convex_count, on_face, normal);
    state = outside ? 1 : 2;
    touched.push_back(index);
  }
  return state == 1;
}

void ShaftCuller::drop_hidden_occluders(const Vec3& x, std::vector<int>& faces, int on_face, const Vec3* normal) const {
  thread_local std::vector<signed char> outside_state;
  thread_local std::vector<int> touched;
  drop_hidden_occluders(x, faces, on_face, normal, outside_state, touched);
  for (int solid : touched) outside_state[size_t(solid)] = 0;
  touched.clear();
}

void ShaftCuller::drop_hidden_occluders(const Vec3& x, std::vector<int>& faces, int on_face, const Vec3* normal,
                                        std::vector<signed char>& outside_state, std::vector<int>& touched) const {
  if (solids_.empty() && closed_solids_.empty()) return;
  outside_state.resize(solids_.size() + closed_solids_.size(), 0);
  size_t kept = 0;
  for (int f : faces)
    if (!hidden_from(x, f, on_face, normal, outside_state, touched)) faces[kept++] = f;
  faces.resize(kept);
}

}  // namespace photometria
