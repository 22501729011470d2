#include "patching/patching.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdio>
#include <map>
#include <numeric>

#include "util/error.h"

namespace photometria {

Polygon PatchMesh::polygon(int i) const {
  const Patch& p = patches[i];
  Polygon poly(p.corner_count);
  for (int k = 0; k < p.corner_count; ++k) poly[k] = points[p.corners[k]];
  return poly;
}

namespace {

struct UnionFind {
  std::vector<int> parent;
  explicit UnionFind(int n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  int find(int x) { return parent[x] == x ? x : parent[x] = find(parent[x]); }
  void unite(int a, int b) { parent[find(a)] = find(b); }
};

// A mesh edge, stored once with its vertices in increasing order, with its interior points.
struct Edge {
  int lo = 0, hi = 0;
  long long segments = 1;     // ≤ kMaxSegments; subdivide() runs only when the whole mesh fits an int
  std::vector<int> interior;  // point indices from lo towards hi
};

// "1.2e+12": a count too large for an integer.
std::string approximate(double count) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", count);
  return text;
}

// Segment counts are clamped here, far above anything that fits in memory, so that an absurd
// --max-edge (1e-300) counts as huge instead of overflowing.
constexpr long long kMaxSegments = 1LL << 40;

class Subdivider {
 public:
  Subdivider(const Scene& scene, const PatchingOptions& options) : scene_(scene), options_(options) {}

  PatchGrid count() {
    collect_edges();
    choose_segment_counts();
    PatchGrid g;
    g.segments.assign(scene_.faces.size(), {0.0, 0.0});
    g.points = static_cast<double>(scene_.vertices.size());
    for (const Edge& e : edges_) g.points += static_cast<double>(e.segments - 1);
    for (size_t f = 0; f < scene_.faces.size(); ++f) {
      if (scene_.faces[f].obstruction_only) continue;
      const auto& c = scene_.faces[f].vertices;
      const double nu = static_cast<double>(segments(c[0], c[1]));
      const double nv = c.size() == 4 ? static_cast<double>(segments(c[1], c[2])) : nu;
      g.segments[f] = {nu, nv};
      g.patches += nu * nv;
      // Interior grid points: (nu − 1)(nv − 1) in a quad, (n − 1)(n − 2)/2 in a triangle.
      g.points += c.size() == 4 ? (nu - 1) * (nv - 1) : (nu - 1) * (nu - 2) / 2;
    }
    return g;
  }

  PatchMesh run() {
    const PatchGrid grid = count();
    if (!grid.fits_int())
      throw_bad_input("patching would make " + approximate(grid.patches) +
                      " patches, more than a mesh can index; raise --max-edge");
    mesh_.points = scene_.vertices;  // original vertices keep their indices
    create_edge_points();
    for (int f = 0; f < static_cast<int>(scene_.faces.size()); ++f) {
      if (scene_.faces[f].obstruction_only) continue;  // occluder only: no patches
      if (scene_.faces[f].vertices.size() == 4) split_quad(f);
      else split_triangle(f);
    }
    return std::move(mesh_);
  }

 private:
  const Scene& scene_;
  PatchingOptions options_;
  PatchMesh mesh_;
  std::vector<Edge> edges_;
  std::map<std::pair<int, int>, int> edge_index_;
  std::vector<std::vector<int>> face_edges_;

  int edge_id(int a, int b) {
    const auto key = std::minmax(a, b);
    auto [it, inserted] = edge_index_.try_emplace({key.first, key.second}, static_cast<int>(edges_.size()));
    if (inserted) edges_.push_back({key.first, key.second, 1, {}});
    return it->second;
  }

  void collect_edges() {
    face_edges_.resize(scene_.faces.size());
    for (size_t f = 0; f < scene_.faces.size(); ++f) {
      const auto& v = scene_.faces[f].vertices;
      for (size_t k = 0; k < v.size(); ++k) face_edges_[f].push_back(edge_id(v[k], v[(k + 1) % v.size()]));
    }
  }

  long long needed_segments(double length) const {
    if (options_.max_edge <= 0) return 1;
    return clamp_segments(std::ceil(length / options_.max_edge - 1e-9));
  }
  static long long clamp_segments(double n) {
    return n >= double(kMaxSegments) ? kMaxSegments : std::max(1LL, static_cast<long long>(n));
  }

  void choose_segment_counts() {
    UnionFind tied(static_cast<int>(edges_.size()));
    std::vector<long long> need(edges_.size(), 1);
    for (size_t e = 0; e < edges_.size(); ++e)
      need[e] = needed_segments((scene_.vertices[edges_[e].hi] - scene_.vertices[edges_[e].lo]).norm());
    for (size_t f = 0; f < scene_.faces.size(); ++f) {
      const auto& fe = face_edges_[f];
      if (fe.size() == 4) {
        tied.unite(fe[0], fe[2]);
        tied.unite(fe[1], fe[3]);
      } else {
        tied.unite(fe[0], fe[1]);
        tied.unite(fe[1], fe[2]);
      }
      if (options_.max_area > 0) {
        // nu·nv >= n² segments with n = ceil(sqrt(area / max_area)) keeps every patch small enough.
        const double area = polygon_area(scene_.face_polygon(static_cast<int>(f)));
        const long long n = clamp_segments(std::ceil(std::sqrt(area / options_.max_area) - 1e-9));
        for (int e : fe) need[e] = std::max(need[e], n);
      }
    }
    std::vector<long long> group_need(edges_.size(), 1);
    for (size_t e = 0; e < edges_.size(); ++e) {
      long long& g = group_need[tied.find(static_cast<int>(e))];
      g = std::max(g, need[e]);
    }
    for (size_t e = 0; e < edges_.size(); ++e) edges_[e].segments = group_need[tied.find(static_cast<int>(e))];
  }

  void create_edge_points() {
    for (Edge& e : edges_) {
      const Vec3 a = scene_.vertices[e.lo], b = scene_.vertices[e.hi];
      for (int k = 1; k < e.segments; ++k) {
        e.interior.push_back(static_cast<int>(mesh_.points.size()));
        mesh_.points.push_back(a + (b - a) * (double(k) / e.segments));
      }
    }
  }

  // Point k (0..segments) along the face edge from vertex `from` to vertex `to`.
  int edge_point(int from, int to, int k) {
    const Edge& e = edges_[edge_index_.at({std::min(from, to), std::max(from, to)})];
    if (k == 0) return from;
    if (k == e.segments) return to;
    return from == e.lo ? e.interior[k - 1] : e.interior[e.segments - k - 1];
  }

  long long segments(int a, int b) { return edges_[edge_index_.at({std::min(a, b), std::max(a, b)})].segments; }

  int add_point(const Vec3& x) {
    mesh_.points.push_back(x);
    return static_cast<int>(mesh_.points.size()) - 1;
  }

  void add_patch(int face, std::initializer_list<int> corners) {
    Patch p;
    p.face = face;
    p.corner_count = static_cast<int>(corners.size());
    std::copy(corners.begin(), corners.end(), p.corners.begin());
    const Polygon poly = [&] {
      Polygon q;
      for (int c : corners) q.push_back(mesh_.points[c]);
      return q;
    }();
    p.normal = polygon_normal(scene_.face_polygon(face));
    p.area = polygon_area(poly);
    p.centroid = polygon_centroid(poly);
    mesh_.patches.push_back(p);
  }

  void split_quad(int f) {
    const auto& c = scene_.faces[f].vertices;
    const int nu = static_cast<int>(segments(c[0], c[1])), nv = static_cast<int>(segments(c[1], c[2]));
    const Polygon q = scene_.face_polygon(f);
    // Grid point (i, j): on the boundary from the shared edge points, inside from the bilinear map.
    std::vector<int> grid((nu + 1) * (nv + 1));
    auto at = [&](int i, int j) -> int& { return grid[j * (nu + 1) + i]; };
    for (int j = 0; j <= nv; ++j)
      for (int i = 0; i <= nu; ++i) {
        if (j == 0) at(i, j) = edge_point(c[0], c[1], i);
        else if (i == nu) at(i, j) = edge_point(c[1], c[2], j);
        else if (j == nv) at(i, j) = edge_point(c[2], c[3], nu - i);
        else if (i == 0) at(i, j) = edge_point(c[3], c[0], nv - j);
        else {
          const double s = double(i) / nu, t = double(j) / nv;
          at(i, j) = add_point((1 - s) * (1 - t) * q[0] + s * (1 - t) * q[1] + s * t * q[2] + (1 - s) * t * q[3]);
        }
      }
    for (int j = 0; j < nv; ++j)
      for (int i = 0; i < nu; ++i) add_patch(f, {at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)});
  }

  void split_triangle(int f) {
    const auto& c = scene_.faces[f].vertices;
    const int n = static_cast<int>(segments(c[0], c[1]));
    const Polygon t = scene_.face_polygon(f);
    // Barycentric grid (i, j), i + j <= n: x = c0 + i/n (c1 - c0) + j/n (c2 - c0).
    std::vector<int> grid((n + 1) * (n + 1), -1);
    auto at = [&](int i, int j) -> int& { return grid[j * (n + 1) + i]; };
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i + j <= n; ++i) {
        if (j == 0) at(i, j) = edge_point(c[0], c[1], i);
        else if (i + j == n) at(i, j) = edge_point(c[1], c[2], j);
        else if (i == 0) at(i, j) = edge_point(c[2], c[0], n - j);
        else at(i, j) = add_point(t[0] + (t[1] - t[0]) * (double(i) / n) + (t[2] - t[0]) * (double(j) / n));
      }
    for (int j = 0; j < n; ++j)
      for (int i = 0; i + j < n; ++i) {
        add_patch(f, {at(i, j), at(i + 1, j), at(i, j + 1)});
        if (i + j + 1 < n) add_patch(f, {at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)});
      }
  }
};

}  // namespace

PatchMesh subdivide(const Scene& scene, const PatchingOptions& options) { return Subdivider(scene, options).run(); }

bool PatchGrid::fits_int() const { return patches <= INT_MAX && points <= INT_MAX; }

PatchGrid count_patches(const Scene& scene, const PatchingOptions& options) {
  return Subdivider(scene, options).count();
}

ImplicitPatches::ImplicitPatches(const Scene& scene, const PatchGrid& grid) : scene_(scene), grid_(grid) {
  face_end_.reserve(grid.segments.size());
  for (const auto& nm : grid.segments) {
    patches_ += static_cast<long long>(nm[0]) * static_cast<long long>(nm[1]);
    face_end_.push_back(patches_);
  }
}

ImplicitPatch ImplicitPatches::operator[](long long index) const {
  ImplicitPatch p;
  p.face = static_cast<int>(std::upper_bound(face_end_.begin(), face_end_.end(), index) - face_end_.begin());
  const long long local = index - (p.face > 0 ? face_end_[size_t(p.face) - 1] : 0);
  const Polygon q = scene_.face_polygon(p.face);
  const long long nu = static_cast<long long>(grid_.segments[size_t(p.face)][0]);
  if (q.size() == 4) {
    // subdivide()'s split_quad: row j, column i, corners (i, j) (i+1, j) (i+1, j+1) (i, j+1) of
    // the bilinear map.
    const long long nv = static_cast<long long>(grid_.segments[size_t(p.face)][1]);
    const long long j = local / nu, i = local % nu;
    auto at = [&](long long a, long long b) {
      const double s = double(a) / double(nu), t = double(b) / double(nv);
      return Vec3((1 - s) * (1 - t) * q[0] + s * (1 - t) * q[1] + s * t * q[2] + (1 - s) * t * q[3]);
    };
    p.corner_count = 4;
    p.corners[0] = at(i, j), p.corners[1] = at(i + 1, j), p.corners[2] = at(i + 1, j + 1), p.corners[3] = at(i, j + 1);
    return p;
  }
  // split_triangle: row j holds 2 (n − j) − 1 triangles, "up" (i, j) (i+1, j) (i, j+1) at even
  // places and "down" (i+1, j) (i+1, j+1) (i, j+1) at odd ones; rows before j hold j (2n − j).
  const long long n = nu;
  long long j = static_cast<long long>(double(n) - std::sqrt(std::max(0.0, double(n) * double(n) - double(local))));
  while (j > 0 && j * (2 * n - j) > local) --j;
  while ((j + 1) * (2 * n - j - 1) <= local) ++j;
  const long long t = local - j * (2 * n - j), i = t / 2;
  auto at = [&](long long a, long long b) {
    return Vec3(q[0] + (q[1] - q[0]) * (double(a) / double(n)) + (q[2] - q[0]) * (double(b) / double(n)));
  };
  p.corner_count = 3;
  if (t % 2 == 0) p.corners[0] = at(i, j), p.corners[1] = at(i + 1, j), p.corners[2] = at(i, j + 1);
  else p.corners[0] = at(i + 1, j), p.corners[1] = at(i + 1, j + 1), p.corners[2] = at(i, j + 1);
  return p;
}

}  // namespace photometria
