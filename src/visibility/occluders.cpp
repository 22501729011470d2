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

// The turn of the path a → b → c seen from the side n points to: the sine and cosine of the
// angle between its two edges (a degenerate edge counts as turning straight back).
void turn_at(const std::vector<Vec3>& points, const Vec3& n, int a, int b, int c, double& sine, double& cosine) {
  const Vec3 e1 = points[size_t(b)] - points[size_t(a)], e2 = points[size_t(c)] - points[size_t(b)];
  const double scale = e1.norm() * e2.norm();
  sine = scale > 0.0 ? n.dot(e1.cross(e2)) / scale : 0.0;
  cosine = scale > 0.0 ? e1.dot(e2) / scale : -1.0;
}

// Whether a boundary may turn a → b → c and stay convex: left, or straight on (convex_union's
// own test, so that this never refuses what convex_union would accept).
bool convex_corner(const std::vector<Vec3>& points, const Vec3& n, int a, int b, int c) {
  double s, co;
  turn_at(points, n, a, b, c, s, co);
  return s > 1e-12 || (std::abs(s) <= 1e-12 && co > 0.0);
}

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
  auto turn = [&](int a, int b, int c, double& sine, double& cosine) { turn_at(points, n, a, b, c, sine, cosine); };
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

// A plane's group of faces that is not one convex polygon, split into convex pieces: each piece
// in turn (from the lowest face) merged with a neighbouring piece (lowest first) while their
// union is convex, until no two neighbours merge. Appends the pieces to `out`.
//
// Two convex pieces meet along one straight run of shared edges, and their union is convex
// exactly when it turns convexly where the run begins and ends (the other corners are theirs,
// and the turning then sums to one turn). So a merge is tested at those two corners and made by
// splicing the two boundaries (circular lists of the faces' directed edges) there: its cost is
// the run's length, and growing a piece costs its boundary per merge, not per neighbour tried.
// Faces that are not convex, or not within tol of the group's plane, stay pieces of their own.
// Every piece is checked once more as a whole at the end (convex_union), and one that fails
// (numerically degenerate input) goes back to its faces.
void grow_convex_pieces(const std::vector<int>& faces, const std::vector<std::vector<int>>& corners,
                        const std::vector<double>& face_area, const Vec3& n, double d, const std::vector<Vec3>& points,
                        double tol, MergedOccluders& out) {
  // Directed edges of the group's faces: from, to, their face's piece, the boundary around it.
  std::vector<int> from, to, piece_of_edge, next, prev;
  std::vector<int> head, size;  // per piece: an edge of its boundary, the boundary's length
  std::vector<double> piece_area;
  std::vector<char> alive, mergeable;
  std::vector<std::vector<int>> piece_faces;
  std::vector<Edge> edges, boundary;
  std::vector<int> loop;
  for (int f : faces) {
    const std::vector<int>& c = corners[size_t(f)];
    const int first = static_cast<int>(from.size()), k = static_cast<int>(c.size());
    const int p = static_cast<int>(head.size());
    edges.clear();
    for (int i = 0; i < k; ++i) {
      from.push_back(c[size_t(i)]);
      to.push_back(c[size_t((i + 1) % k)]);
      piece_of_edge.push_back(p);
      next.push_back(first + (i + 1) % k);
      prev.push_back(first + (i + k - 1) % k);
      edges.emplace_back(c[size_t(i)], c[size_t((i + 1) % k)]);
    }
    head.push_back(first);
    size.push_back(k);
    piece_area.push_back(face_area[size_t(f)]);
    alive.push_back(1);
    mergeable.push_back(convex_union(edges, face_area[size_t(f)], n, d, points, tol, boundary, loop));
    piece_faces.push_back({f});
  }
  // The reverse of each edge within the group (-1: none, or a directed edge used twice).
  std::vector<int> twin(from.size(), -1);
  {
    std::unordered_map<uint64_t, int> edge_of;
    edge_of.reserve(from.size() * 2);
    for (size_t e = 0; e < from.size(); ++e) {
      const auto [it, fresh] = edge_of.emplace(key(from[e], to[e]), static_cast<int>(e));
      if (!fresh) it->second = -1;
    }
    for (size_t e = 0; e < from.size(); ++e) {
      const auto it = edge_of.find(key(to[e], from[e]));
      if (it != edge_of.end() && it->second >= 0 && edge_of.at(key(from[e], to[e])) == int(e)) twin[e] = it->second;
    }
  }
  // Pieces absorbed into others point to them (union–find); shared edges become interior.
  std::vector<int> absorbed_by(head.size());
  std::iota(absorbed_by.begin(), absorbed_by.end(), 0);
  std::vector<char> interior(from.size(), 0);
  auto piece = [&](int e) {
    int p = piece_of_edge[size_t(e)];
    while (absorbed_by[size_t(p)] != p) p = absorbed_by[size_t(p)] = absorbed_by[size_t(absorbed_by[size_t(p)])];
    return p;
  };
  // The piece across boundary edge e (-1: none that may merge).
  auto across = [&](int e) {
    const int t = twin[size_t(e)];
    if (t < 0 || interior[size_t(t)]) return -1;
    const int q = piece(t);
    return mergeable[size_t(q)] ? q : -1;
  };
  // The run of edges p shares with neighbour q, found from one of them (e): first..last along
  // p's boundary, when their union is convex (the test at the run's two ends).
  auto convex_union_across = [&](int p, int q, int e, int& first, int& last, int& run) {
    first = last = e;
    run = 1;
    while (run < size[size_t(p)] && across(prev[size_t(first)]) == q) first = prev[size_t(first)], ++run;
    while (run < size[size_t(p)] && across(next[size_t(last)]) == q) last = next[size_t(last)], ++run;
    if (run >= size[size_t(p)] || run >= size[size_t(q)]) return false;
    for (int x = first; x != last; x = next[size_t(x)])  // q's run must be one piece of its boundary too
      if (next[size_t(twin[size_t(next[size_t(x)])])] != twin[size_t(x)]) return false;
    const int q_first = twin[size_t(first)], q_last = twin[size_t(last)];  // q's run runs back from q_last to q_first
    return convex_corner(points, n, from[size_t(prev[size_t(first)])], from[size_t(first)],
                         to[size_t(next[size_t(q_first)])]) &&
           convex_corner(points, n, from[size_t(prev[size_t(q_last)])], to[size_t(last)],
                         to[size_t(next[size_t(last)])]);
  };
  // Merges piece q into p along their shared run first..last (p's edges): the boundaries spliced.
  auto merge = [&](int p, int q, int first, int last, int run) {
    for (int x = first;; x = next[size_t(x)]) {
      interior[size_t(x)] = interior[size_t(twin[size_t(x)])] = 1;
      if (x == last) break;
    }
    const int q_first = twin[size_t(first)], q_last = twin[size_t(last)];
    const int before = prev[size_t(first)], after = next[size_t(last)];
    const int q_after = next[size_t(q_first)], q_before = prev[size_t(q_last)];
    next[size_t(before)] = q_after, prev[size_t(q_after)] = before;
    next[size_t(q_before)] = after, prev[size_t(after)] = q_before;
    head[size_t(p)] = before;
    size[size_t(p)] += size[size_t(q)] - 2 * run;
    piece_area[size_t(p)] += piece_area[size_t(q)];
    piece_faces[size_t(p)].insert(piece_faces[size_t(p)].end(), piece_faces[size_t(q)].begin(),
                                  piece_faces[size_t(q)].end());
    piece_faces[size_t(q)].clear();
    absorbed_by[size_t(q)] = p;
    alive[size_t(q)] = 0;
  };
  // Each piece takes, while it can, the lowest neighbour whose union with it is convex: every
  // neighbour is tested once per merge (seen[] marks the tested ones), without sorting them.
  std::vector<int> seen(head.size(), -1);
  int scan = 0;
  for (bool changed = true; changed;) {
    changed = false;
    for (int p = 0; p < static_cast<int>(head.size()); ++p) {
      if (!alive[size_t(p)] || !mergeable[size_t(p)]) continue;
      for (;;) {
        ++scan;
        int best = -1, best_first = 0, best_last = 0, best_run = 0;
        int e = head[size_t(p)];
        for (int i = 0; i < size[size_t(p)]; ++i, e = next[size_t(e)]) {
          const int q = across(e);
          if (q < 0 || q == p || (best >= 0 && q > best) || seen[size_t(q)] == scan) continue;
          seen[size_t(q)] = scan;
          int first, last, run;
          if (convex_union_across(p, q, e, first, last, run))
            best = q, best_first = first, best_last = last, best_run = run;
        }
        if (best < 0) break;
        merge(p, best, best_first, best_last, best_run);
        changed = true;
      }
    }
  }
  for (size_t p = 0; p < head.size(); ++p) {
    if (!alive[p]) continue;
    std::vector<int>& pf = piece_faces[p];
    std::sort(pf.begin(), pf.end());
    if (pf.size() == 1) {
      out.faces.push_back(pf);
      out.corners.push_back(corners[size_t(pf[0])]);
      continue;
    }
    edges.clear();
    int e = head[p];
    for (int i = 0; i < size[p]; ++i, e = next[size_t(e)]) edges.emplace_back(from[size_t(e)], to[size_t(e)]);
    if (convex_union(edges, piece_area[p], n, d, points, tol, boundary, loop)) {
      out.faces.push_back(pf);
      out.corners.push_back(loop);
    } else {
      for (int f : pf) {
        out.faces.push_back({f});
        out.corners.push_back(corners[size_t(f)]);
      }
    }
  }
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
    grow_convex_pieces(faces, corners, area, nr, dr, scene.vertices, tol, out);
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
