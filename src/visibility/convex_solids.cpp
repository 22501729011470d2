// Convexity among the scene's faces and occluders: a scene that is one convex enclosure needs no
// visibility at all (scene_needs_no_visibility, over the faces), and the convex solids among the
// occluders (closed, consistently oriented components of occluders, such as boxes, however
// finely their faces are meshed) cast their shadow through the occluders toward a point outside
// them only (ShaftCuller::drop_hidden_occluders; shadow_clipping.cpp builds their one shadow
// volume from the solids and occluder neighbours found here).
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
  for (size_t f = 0; f < scene.faces.size(); ++f) {
    const Polygon poly = scene.face_polygon(static_cast<int>(f));
    const Vec3 n = polygon_normal(poly);
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
    if (!eligible) continue;
    const int id = static_cast<int>(solids_.size());
    solids_.push_back(faces);
    for (int f : faces) solid_of_[size_t(f)] = id;
  }
}

bool ShaftCuller::hidden_from(const Vec3& x, int f, std::vector<signed char>& outside_state,
                              std::vector<int>& touched) const {
  const int solid = solid_of_[size_t(f)];
  // Signed distance of x in front of occluder g's plane.
  auto height = [&](int g) { return normals_[size_t(g)].dot(x - occluders_[size_t(g)][0]); };
  if (solid < 0 || !(height(f) < -tol_)) return false;
  signed char& state = outside_state[size_t(solid)];
  if (state == 0) {
    bool outside = false;
    for (int g : solids_[size_t(solid)]) outside = outside || height(g) > tol_;
    state = outside ? 1 : 2;
    touched.push_back(solid);
  }
  return state == 1;
}

void ShaftCuller::drop_hidden_occluders(const Vec3& x, std::vector<int>& faces) const {
  if (solids_.empty()) return;
  thread_local std::vector<signed char> outside_state;
  thread_local std::vector<int> touched;
  outside_state.resize(solids_.size(), 0);
  size_t kept = 0;
  for (int f : faces)
    if (!hidden_from(x, f, outside_state, touched)) faces[kept++] = f;
  faces.resize(kept);
  for (int solid : touched) outside_state[size_t(solid)] = 0;
  touched.clear();
}

}  // namespace photometria
