// Cleaning the geometry so later stages can trust it: every face a triangle or a planar convex
// quad with positive area, counter-clockwise from its front, over welded vertices.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <set>

#include "scene/loaders.h"

namespace photometria::scene_detail {
namespace {

// Faces with area below this fraction of diagonal² are dropped as zero-area: rounding noise
// of coordinates is ~1e-16 of the diagonal, so such faces carry no real area.
constexpr double kZeroArea = 1e-14;

double used_diagonal(const Scene& s) {
  const double inf = std::numeric_limits<double>::infinity();
  Vec3 lo = Vec3::Constant(inf), hi = Vec3::Constant(-inf);
  for (const Face& f : s.faces)
    for (int v : f.vertices) {
      lo = lo.cwiseMin(s.vertices[static_cast<size_t>(v)]);
      hi = hi.cwiseMax(s.vertices[static_cast<size_t>(v)]);
    }
  return s.faces.empty() ? 0.0 : (hi - lo).norm();
}

// After welding a face may visit a vertex twice in a row (also last -> first). The corner
// normals go with their corners: of a repeat, the first corner's normal is kept.
void drop_repeats(Face& f) {
  std::vector<int>& v = f.vertices;
  std::vector<Vec3>& n = f.corner_normals;
  const bool normals = n.size() == v.size();
  size_t kept = 0;
  for (size_t k = 0; k < v.size(); ++k)
    if (kept == 0 || v[k] != v[kept - 1]) {
      v[kept] = v[k];
      if (normals) n[kept] = n[k];
      ++kept;
    }
  while (kept > 1 && v[0] == v[kept - 1]) --kept;
  v.resize(kept);
  if (normals) n.resize(kept);
}

int distinct_count(std::vector<int> v) {
  std::sort(v.begin(), v.end());
  return static_cast<int>(std::unique(v.begin(), v.end()) - v.begin());
}

double diameter(const Polygon& p) {
  double d = 0;
  for (size_t i = 0; i < p.size(); ++i)
    for (size_t j = i + 1; j < p.size(); ++j) d = std::max(d, (p[i] - p[j]).norm());
  return d;
}

using Triangles = std::vector<std::array<int, 3>>;

// Both triangles of a quad split face the same way as the quad (the diagonal lies inside).
bool folds_consistently(const Polygon& p, const Triangles& t) {
  const Vec3 n = newell_vector(p);
  for (const auto& [a, b, c] : t)
    if ((p[b] - p[a]).cross(p[c] - p[a]).dot(n) <= 0) return false;
  return true;
}

// A non-planar quad: along its shorter diagonal, unless only the other one lies inside.
Triangles split_quad(const Polygon& p) {
  const Triangles d02 = {{{0, 1, 2}, {0, 2, 3}}}, d13 = {{{1, 2, 3}, {1, 3, 0}}};
  const bool short02 = (p[0] - p[2]).norm() <= (p[1] - p[3]).norm();
  const Triangles& first = short02 ? d02 : d13;
  const Triangles& second = short02 ? d13 : d02;
  return folds_consistently(p, first) || !folds_consistently(p, second) ? first : second;
}

// Ear clipping; a fan when that fails (self-intersecting input) so no area goes missing.
Triangles triangulate(const Polygon& p) {
  Triangles t = triangulate_polygon(p);
  if (t.size() == p.size() - 2) return t;
  t.clear();
  for (int i = 1; i + 1 < static_cast<int>(p.size()); ++i) t.push_back({0, i, i + 1});
  return t;
}

class FaceCleaner {
 public:
  FaceCleaner(const Scene& s, const LoadOptions& o, LoadStats& stats)
      : scene_(s), options_(o), stats_(stats), min_area_(kZeroArea * std::pow(used_diagonal(s), 2)) {}

  // Appends `f` (indices already welded) to `out`, as it is, split, or not at all.
  void add(Face f, std::vector<Face>& out) {
    drop_repeats(f);
    const Polygon p = polygon(f.vertices);
    if (distinct_count(f.vertices) < 3 || polygon_area(p) <= min_area_) {
      ++stats_.dropped_degenerate;
      return;
    }
    const bool planar = planarity_deviation(p) <= options_.planarity_tolerance * diameter(p);
    if (p.size() == 3 || (p.size() == 4 && planar && is_convex(p))) {
      out.push_back(std::move(f));
      return;
    }
    ++(planar ? stats_.split_polygons : stats_.split_nonplanar);
    const Triangles pieces = !planar && p.size() == 4 ? split_quad(p) : triangulate(p);
    for (const auto& [a, b, c] : pieces) {
      // The pieces keep the face's material, groups and the normals of the corners they keep.
      Face t = f;
      t.vertices = {f.vertices[static_cast<size_t>(a)], f.vertices[static_cast<size_t>(b)],
                    f.vertices[static_cast<size_t>(c)]};
      if (!f.corner_normals.empty())
        t.corner_normals = {f.corner_normals[static_cast<size_t>(a)], f.corner_normals[static_cast<size_t>(b)],
                            f.corner_normals[static_cast<size_t>(c)]};
      // Pieces of zero area (collinear vertices of the polygon) carry nothing.
      if (polygon_area(polygon(t.vertices)) > min_area_) out.push_back(std::move(t));
    }
  }

 private:
  Polygon polygon(const std::vector<int>& v) const {
    Polygon p;
    for (int i : v) p.push_back(scene_.vertices[static_cast<size_t>(i)]);
    return p;
  }

  const Scene& scene_;
  const LoadOptions& options_;
  LoadStats& stats_;
  double min_area_;
};

// Keeps only the vertices that faces use, in their original order.
void drop_unused_vertices(Scene& s) {
  std::vector<int> index(s.vertices.size(), -1);
  for (const Face& f : s.faces)
    for (int v : f.vertices) index[static_cast<size_t>(v)] = 0;
  std::vector<Vec3> kept;
  for (size_t i = 0; i < s.vertices.size(); ++i)
    if (index[i] == 0) {
      index[i] = static_cast<int>(kept.size());
      kept.push_back(s.vertices[i]);
    }
  for (Face& f : s.faces)
    for (int& v : f.vertices) v = index[static_cast<size_t>(v)];
  s.vertices = std::move(kept);
}

}  // namespace

void clean_geometry(Scene& scene, const LoadOptions& options) {
  std::vector<bool> used(scene.vertices.size(), false);
  for (const Face& f : scene.faces)
    for (int v : f.vertices) used[static_cast<size_t>(v)] = true;
  const double tolerance = std::max(0.0, options.weld_tolerance) * used_diagonal(scene);
  const std::vector<int> weld = weld_points(scene.vertices, used, tolerance, scene.stats.welded_vertices);

  FaceCleaner cleaner(scene, options, scene.stats);
  std::vector<Face> cleaned;
  for (Face f : scene.faces) {
    for (int& v : f.vertices) v = weld[static_cast<size_t>(v)];
    cleaner.add(std::move(f), cleaned);
  }
  scene.faces = std::move(cleaned);
  drop_unused_vertices(scene);
}

void drop_duplicate_faces(Scene& scene) {
  // Key: the vertex cycle started at its smallest index, winding kept, so that a face and its
  // rotations compare equal while a back-to-back twin (reverse winding) does not.
  std::set<std::vector<int>> seen;
  std::vector<Face> kept;
  kept.reserve(scene.faces.size());
  for (Face& f : scene.faces) {
    std::vector<int> key = f.vertices;
    std::rotate(key.begin(), std::min_element(key.begin(), key.end()), key.end());
    if (!seen.insert(std::move(key)).second) {
      ++scene.stats.duplicate_faces;
      continue;
    }
    kept.push_back(std::move(f));
  }
  scene.faces = std::move(kept);
}

}  // namespace photometria::scene_detail
