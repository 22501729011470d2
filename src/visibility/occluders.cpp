// Occluders from surfaces, not faces (visibility.h, ShaftCuller): coplanar, edge-connected scene
// faces of one orientation merged into convex polygons covering exactly the points they cover.
// A wall meshed into n × n quads is one occluder, so exact visibility costs what the surfaces
// that matter cost, not what the face count does.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <numeric>
#include <unordered_map>
#include <utility>
#include <vector>

#include "visibility/visibility.h"
#include "visibility/visibility_internal.h"

namespace photometria::visibility_detail {

namespace {

using Edge = std::pair<int, int>;  // directed, between scene vertex indices

uint64_t key(int a, int b) { return (uint64_t(uint32_t(a)) << 32) | uint32_t(b); }

// The union of convex polygons of one plane (unit normal n, n·y = d) given by their directed
// edges (each polygon counter-clockwise around n), when it is one convex polygon: interior edges
// cancel against their reverse, what is left must be one loop through distinct corners, within
// tol of the plane, convex once collinear corners are removed (turning once around), of area
// `area` (the polygons' sum: they do not overlap) within 1e-9 relative. Gives the remaining
// edges (`boundary`, collinear corners kept: a neighbour's edges may end there) and the convex
// polygon's corners (`loop`, from its smallest id).
bool convex_union(const std::vector<Edge>& edges, double area, const Vec3& n, double d, const std::vector<Vec3>& points,
                  double tol, std::vector<Edge>& boundary, std::vector<int>& loop) {
  std::unordered_map<uint64_t, int> count;
  count.reserve(edges.size() * 2);
  for (const Edge& e : edges)
    if (++count[key(e.first, e.second)] > 1) return false;  // overlapping polygons
  boundary.clear();
  for (const Edge& e : edges)
    if (!count.count(key(e.second, e.first))) boundary.push_back(e);
  if (boundary.size() < 3) return false;
  std::unordered_map<int, int> next;
  next.reserve(boundary.size() * 2);
  for (const Edge& e : boundary)
    if (!next.emplace(e.first, e.second).second) return false;  // a corner met twice: not one simple loop
  std::vector<int> all;
  const int start = boundary[0].first;
  int v = start;
  do {
    all.push_back(v);
    const auto it = next.find(v);
    if (it == next.end() || all.size() > boundary.size()) return false;
    v = it->second;
  } while (v != start);
  if (all.size() != boundary.size()) return false;  // more than one loop (a hole, or apart)
  for (int c : all)
    if (std::abs(n.dot(points[size_t(c)]) - d) > tol) return false;
  const size_t m = all.size();
  auto turn = [&](int a, int b, int c, double& sine, double& cosine) {
    const Vec3 e1 = points[size_t(b)] - points[size_t(a)], e2 = points[size_t(c)] - points[size_t(b)];
    const double scale = e1.norm() * e2.norm();
    sine = scale > 0.0 ? n.dot(e1.cross(e2)) / scale : 0.0;
    cosine = scale > 0.0 ? e1.dot(e2) / scale : -1.0;
  };
  loop.clear();
  for (size_t i = 0; i < m; ++i) {
    double s, c;
    turn(all[(i + m - 1) % m], all[i], all[(i + 1) % m], s, c);
    if (!(std::abs(s) <= 1e-12 && c > 0.0)) loop.push_back(all[i]);  // not straight on
  }
  const size_t k = loop.size();
  if (k < 3) return false;
  double turning = 0.0;
  for (size_t i = 0; i < k; ++i) {
    double s, c;
    turn(loop[(i + k - 1) % k], loop[i], loop[(i + 1) % k], s, c);
    if (!(s > 1e-12)) return false;  // a reflex (or straight back) corner: not convex
    turning += std::atan2(s, c);
  }
  if (std::abs(turning - 2.0 * std::acos(-1.0)) > 1e-6) return false;
  Polygon p;
  for (int c : loop) p.push_back(points[size_t(c)]);
  if (std::abs(n.dot(newell_vector(p)) * 0.5 - area) > 1e-9 * area) return false;
  std::rotate(loop.begin(), std::min_element(loop.begin(), loop.end()), loop.end());
  return true;
}

}  // namespace

MergedOccluders merge_coplanar_faces(const Scene& scene, double tol) {
  const int n = static_cast<int>(scene.faces.size());
  std::vector<std::vector<int>> corners(static_cast<size_t>(n));
  std::vector<Vec3> normal(static_cast<size_t>(n));
  std::vector<double> offset(static_cast<size_t>(n)), area(static_cast<size_t>(n));
  std::vector<char> mergeable(static_cast<size_t>(n), 1);
  for (int f = 0; f < n; ++f) {
    const Polygon p = scene.face_polygon(f);
    corners[size_t(f)] = scene.faces[size_t(f)].vertices;
    normal[size_t(f)] = polygon_normal(p);
    offset[size_t(f)] = normal[size_t(f)].dot(p[0]);
    area[size_t(f)] = polygon_area(p);
    if (normal[size_t(f)].isZero() || !(area[size_t(f)] > 0.0)) mergeable[size_t(f)] = 0;
  }
  // The face using each directed edge (-1: more than one).
  std::unordered_map<uint64_t, int> owner;
  for (int f = 0; f < n; ++f) {
    const std::vector<int>& c = corners[size_t(f)];
    for (size_t k = 0; k < c.size(); ++k) {
      const auto [it, fresh] = owner.emplace(key(c[k], c[(k + 1) % c.size()]), f);
      if (!fresh) it->second = -1;
    }
  }
  // Groups: faces joined by shared edges (the reverse directed edge) within one plane, union–find.
  std::vector<int> parent(static_cast<size_t>(n));
  std::iota(parent.begin(), parent.end(), 0);
  auto root = [&](int f) {
    while (parent[size_t(f)] != f) f = parent[size_t(f)] = parent[size_t(parent[size_t(f)])];
    return f;
  };
  auto same_plane = [&](int f, int g) {
    const Vec3 &a = normal[size_t(f)], &b = normal[size_t(g)];
    return a.dot(b) > 0.0 && a.cross(b).norm() <= 1e-9 && std::abs(offset[size_t(f)] - offset[size_t(g)]) <= tol;
  };
  for (int f = 0; f < n; ++f) {
    if (!mergeable[size_t(f)]) continue;
    const std::vector<int>& c = corners[size_t(f)];
    for (size_t k = 0; k < c.size(); ++k) {
      const auto it = owner.find(key(c[(k + 1) % c.size()], c[k]));
      if (it == owner.end() || it->second < 0 || it->second == f || !mergeable[size_t(it->second)]) continue;
      if (!same_plane(f, it->second)) continue;
      const int a = root(f), b = root(it->second);
      if (a != b) parent[size_t(std::max(a, b))] = std::min(a, b);
    }
  }
  std::map<int, std::vector<int>> groups;  // ascending faces per group
  for (int f = 0; f < n; ++f) groups[root(f)].push_back(f);

  MergedOccluders out;
  auto face_edges = [&](int f, std::vector<Edge>& edges) {
    const std::vector<int>& c = corners[size_t(f)];
    for (size_t k = 0; k < c.size(); ++k) edges.emplace_back(c[k], c[(k + 1) % c.size()]);
  };
  std::vector<Edge> edges, boundary;
  std::vector<int> loop;
  for (const auto& [r, faces] : groups) {
    (void)r;
    if (faces.size() == 1) {
      out.faces.push_back(faces);
      out.corners.push_back(corners[size_t(faces[0])]);
      continue;
    }
    const Vec3& nr = normal[size_t(faces[0])];
    const double dr = offset[size_t(faces[0])];
    edges.clear();
    double total = 0.0;
    for (int f : faces) {
      face_edges(f, edges);
      total += area[size_t(f)];
    }
    if (convex_union(edges, total, nr, dr, scene.vertices, tol, boundary, loop)) {
      out.faces.push_back(faces);
      out.corners.push_back(loop);
      continue;
    }
    // Not one convex polygon: grow pieces, each piece in turn merged with a neighbouring piece
    // (lowest first) while their union is convex, until no two neighbours merge.
    struct Piece {
      std::vector<int> faces, loop;
      std::vector<Edge> boundary;
      double area = 0.0;
      bool alive = true;
    };
    std::vector<Piece> pieces;
    std::unordered_map<uint64_t, int> piece_of;  // directed boundary edge -> piece
    for (int f : faces) {
      Piece p;
      p.faces = {f};
      p.loop = corners[size_t(f)];
      face_edges(f, p.boundary);
      p.area = area[size_t(f)];
      for (const Edge& e : p.boundary) piece_of[key(e.first, e.second)] = static_cast<int>(pieces.size());
      pieces.push_back(std::move(p));
    }
    std::vector<int> near;
    for (bool changed = true; changed;) {
      changed = false;
      for (size_t p = 0; p < pieces.size(); ++p) {
        if (!pieces[p].alive) continue;
        for (bool merged = true; merged;) {
          merged = false;
          near.clear();
          for (const Edge& e : pieces[p].boundary) {
            const auto it = piece_of.find(key(e.second, e.first));
            if (it != piece_of.end() && it->second != static_cast<int>(p) && pieces[size_t(it->second)].alive)
              near.push_back(it->second);
          }
          std::sort(near.begin(), near.end());
          near.erase(std::unique(near.begin(), near.end()), near.end());
          for (int q : near) {
            Piece &a = pieces[p], &b = pieces[size_t(q)];
            edges = a.boundary;
            edges.insert(edges.end(), b.boundary.begin(), b.boundary.end());
            if (!convex_union(edges, a.area + b.area, nr, dr, scene.vertices, tol, boundary, loop)) continue;
            a.faces.insert(a.faces.end(), b.faces.begin(), b.faces.end());
            std::sort(a.faces.begin(), a.faces.end());
            a.boundary = boundary;
            a.loop = loop;
            a.area += b.area;
            b.alive = false;
            for (const Edge& e : a.boundary) piece_of[key(e.first, e.second)] = static_cast<int>(p);
            merged = changed = true;
            break;
          }
        }
      }
    }
    for (const Piece& p : pieces)
      if (p.alive) {
        out.faces.push_back(p.faces);
        out.corners.push_back(p.loop);
      }
  }
  // In the order of their first faces: with nothing merged, occluder f is face f.
  std::vector<int> order(out.faces.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return out.faces[size_t(a)][0] < out.faces[size_t(b)][0]; });
  MergedOccluders sorted;
  for (int o : order) {
    sorted.faces.push_back(std::move(out.faces[size_t(o)]));
    sorted.corners.push_back(std::move(out.corners[size_t(o)]));
  }
  return sorted;
}

}  // namespace photometria::visibility_detail
