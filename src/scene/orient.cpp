// Face orientation within closed surfaces.
//
// A closed surface here is a set of faces connected through shared edges in which every edge
// belongs to exactly two faces (after welding). In a consistently oriented closed surface every
// edge is walked once in each direction by its two faces; a face wound the other way has its
// front on the wrong side (a CAD export's flipped panel). Propagating "same side as my
// neighbour" across the shared edges splits such a surface into two classes of faces; the class
// covering the larger area is taken as intended and the other is flipped. Surfaces that are not
// closed (open rooms, T-junctions, edges of three or more faces) are left as they are: there the
// winding alone does not say which side is meant.
//
// Afterwards the signed volume tells whether a closed surface faces out or in:
//   V = (1/6) Σ_faces Σ_fan p_0 · (p_i × p_{i+1})
// (divergence theorem with the signed-tetrahedron decomposition, as in Zhang & Chen, "Efficient
// feature extraction for 2D/3D objects in mesh representation", ICIP 2001), V > 0 when the
// fronts face outward. A surface around the whole scene (a room) should face in; when it faces
// out, the export is probably inside-out throughout and LoadStats::enclosure_faces_outward says
// so (the fix is LoadOptions::flip_normals, which reverses every face).
#include <algorithm>
#include <limits>
#include <map>
#include <numeric>
#include <queue>

#include "scene/loaders.h"

namespace photometria::scene_detail {
namespace {

struct EdgeUse {
  int face;
  bool forward;  // the face walks the edge from the smaller to the larger vertex index
};

using EdgeMap = std::map<std::pair<int, int>, std::vector<EdgeUse>>;

EdgeMap edge_uses(const Scene& s) {
  EdgeMap edges;
  for (size_t f = 0; f < s.faces.size(); ++f) {
    const auto& v = s.faces[f].vertices;
    for (size_t k = 0; k < v.size(); ++k) {
      const int a = v[k], b = v[(k + 1) % v.size()];
      edges[{std::min(a, b), std::max(a, b)}].push_back({static_cast<int>(f), a < b});
    }
  }
  return edges;
}

int find(std::vector<int>& parent, int x) {
  while (parent[static_cast<size_t>(x)] != x)
    x = parent[static_cast<size_t>(x)] = parent[static_cast<size_t>(parent[static_cast<size_t>(x)])];
  return x;
}

struct Box {
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 hi = Vec3::Constant(-std::numeric_limits<double>::infinity());
  void add(const Vec3& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
};

}  // namespace

void fix_orientation(Scene& s, bool flip_inconsistent) {
  const int n = static_cast<int>(s.faces.size());
  const EdgeMap edges = edge_uses(s);

  // Components through shared edges; a component is closed when all its edges have two faces.
  std::vector<int> parent(static_cast<size_t>(n));
  std::iota(parent.begin(), parent.end(), 0);
  for (const auto& [e, uses] : edges)
    for (size_t k = 1; k < uses.size(); ++k)
      parent[static_cast<size_t>(find(parent, uses[k].face))] = find(parent, uses[0].face);
  std::vector<bool> closed(static_cast<size_t>(n), true);
  for (const auto& [e, uses] : edges)
    if (uses.size() != 2) closed[static_cast<size_t>(find(parent, uses[0].face))] = false;
  std::map<int, std::vector<int>> components;
  for (int f = 0; f < n; ++f) components[find(parent, f)].push_back(f);

  // Neighbours across two-face edges, with whether both walk the edge the same way (inconsistent).
  std::vector<std::vector<std::pair<int, bool>>> next(static_cast<size_t>(n));
  for (const auto& [e, uses] : edges)
    if (uses.size() == 2) {
      const bool same = uses[0].forward == uses[1].forward;
      next[static_cast<size_t>(uses[0].face)].push_back({uses[1].face, same});
      next[static_cast<size_t>(uses[1].face)].push_back({uses[0].face, same});
    }

  Box scene_box;
  for (const Face& f : s.faces)
    for (int v : f.vertices) scene_box.add(s.vertices[static_cast<size_t>(v)]);
  const double tol = 1e-9 * (scene_box.hi - scene_box.lo).norm();

  for (const auto& [root, faces] : components) {
    if (!closed[static_cast<size_t>(root)]) continue;
    // side[f] = true: f is wound against the component's first face.
    std::vector<int> side(static_cast<size_t>(n), -1);
    std::queue<int> todo;
    side[static_cast<size_t>(faces[0])] = 0;
    todo.push(faces[0]);
    bool orientable = true;
    while (!todo.empty()) {
      const int f = todo.front();
      todo.pop();
      for (const auto& [g, same] : next[static_cast<size_t>(f)]) {
        const int want = side[static_cast<size_t>(f)] ^ static_cast<int>(same);
        if (side[static_cast<size_t>(g)] < 0) {
          side[static_cast<size_t>(g)] = want;
          todo.push(g);
        } else if (side[static_cast<size_t>(g)] != want) {
          orientable = false;  // a Möbius-like surface: no consistent winding exists
        }
      }
    }
    if (!orientable) continue;
    double area[2] = {0, 0};
    for (int f : faces) area[side[static_cast<size_t>(f)]] += polygon_area(s.face_polygon(f));
    const int minority = area[1] > area[0] ? 0 : 1;  // ties keep the first face's winding
    if (flip_inconsistent)
      for (int f : faces)
        if (side[static_cast<size_t>(f)] == minority) {
          s.faces[static_cast<size_t>(f)].reverse();  // with its corner normals (Face::reverse)
          ++s.stats.flipped_faces;
        }

    Box box;
    for (int f : faces)
      for (int v : s.faces[static_cast<size_t>(f)].vertices) box.add(s.vertices[static_cast<size_t>(v)]);
    const bool encloses =
        (box.lo.array() <= scene_box.lo.array() + tol).all() && (box.hi.array() >= scene_box.hi.array() - tol).all();
    if (encloses && signed_volume(s, faces) > 0) s.stats.enclosure_faces_outward = true;
  }
}

}  // namespace photometria::scene_detail

namespace photometria {

double signed_volume(const Scene& s, const std::vector<int>& faces) {
  double v = 0;
  for (int f : faces) {
    const Polygon p = s.face_polygon(f);
    for (size_t i = 1; i + 1 < p.size(); ++i) v += p[0].dot(p[i].cross(p[i + 1])) / 6.0;
  }
  return v;
}

}  // namespace photometria
