// The written cells, cut at T-junctions (output_cells.h).
#include "pipeline/output_cells.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>

namespace photometria {

namespace {

using Position = std::array<double, 3>;

// +0.0 for −0.0, so that the two zeros name one position.
Position position_key(const Vec3& p) { return {p.x() + 0.0, p.y() + 0.0, p.z() + 0.0}; }

// Whether normal n lies within the arc from a to b (unit vectors), to kArcTolerance.
bool within_arc(const Vec3& n, const Vec3& a, const Vec3& b) {
  constexpr double kArcTolerance = 1e-6;  // radians
  const Vec3 sum = a + b;
  if (sum.norm() < 1e-12) return false;  // opposite normals: no arc between them
  const Vec3 mid = sum.normalized();
  const double half = std::acos(std::min(1.0, mid.dot(a)));
  return std::acos(std::clamp(n.dot(mid), -1.0, 1.0)) <= half + kArcTolerance;
}

class TJunctions {
 public:
  TJunctions(const Scene& scene, const SolveResult& r) : scene_(scene), r_(r) {
    for (int o = 0; o < static_cast<int>(r.points.size()); ++o)
      at_[position_key(r.points[size_t(o)].position)].push_back(o);
  }

  // The points inside edge (a, b) of a patch of `material`, in order from a to b, appended.
  void inside(int a, int b, int material, std::vector<int>& out, int depth = 0) const {
    constexpr int kMaxDepth = 60;  // halvings of a double's edge before its midpoint is an end
    if (depth > kMaxDepth) return;
    const OutputPoint &pa = r_.points[size_t(a)], &pb = r_.points[size_t(b)];
    const Vec3 mid = 0.5 * (pa.position + pb.position);
    const auto it = at_.find(position_key(mid));
    if (it == at_.end()) return;
    for (const int m : it->second) {
      const OutputPoint& pm = r_.points[size_t(m)];
      if (m == a || m == b || pm.material != material || !within_arc(pm.normal, pa.normal, pb.normal)) continue;
      inside(a, m, material, out, depth + 1);
      out.push_back(m);
      inside(m, b, material, out, depth + 1);
      return;
    }
  }

  int material_of(int patch) const { return scene_.faces[size_t(r_.mesh.patches[size_t(patch)].face)].material; }

 private:
  const Scene& scene_;
  const SolveResult& r_;
  std::map<Position, std::vector<int>> at_;
};

double triangle_area(const SolveResult& r, int a, int b, int c) {
  const Vec3 &pa = r.points[size_t(a)].position, &pb = r.points[size_t(b)].position, &pc = r.points[size_t(c)].position;
  return 0.5 * (pb - pa).cross(pc - pa).norm();
}

// Triangles over a convex polygon whose vertices are its corners and points inside its edges
// (`corner` per vertex), none of them degenerate: a corner next to a point inside an edge is
// cut off first (the chord makes that neighbour a corner of what is left, so at least three
// corners always remain), a corner between two corners only when no such point is left.
void triangulate(std::vector<int> polygon, std::vector<char> corner, std::vector<std::array<int, 3>>& triangles) {
  while (polygon.size() > 3) {
    const size_t n = polygon.size();
    size_t cut = n;
    for (size_t k = 0; k < n && cut == n; ++k)
      if (corner[k] && (!corner[(k + 1) % n] || !corner[(k + n - 1) % n])) cut = k;
    if (cut == n) cut = 0;  // only corners left: any of them
    const size_t prev = (cut + n - 1) % n, next = (cut + 1) % n;
    triangles.push_back({polygon[prev], polygon[cut], polygon[next]});
    corner[prev] = corner[next] = 1;
    polygon.erase(polygon.begin() + std::ptrdiff_t(cut));
    corner.erase(corner.begin() + std::ptrdiff_t(cut));
  }
  triangles.push_back({polygon[0], polygon[1], polygon[2]});
}

}  // namespace

OutputCells conforming_cells(const Scene& scene, const SolveResult& r) {
  OutputCells out;
  const TJunctions junctions(scene, r);
  std::vector<int> polygon, on_edge;
  std::vector<char> corner;
  std::vector<std::array<int, 3>> triangles;
  for (int i = 0; i < static_cast<int>(r.cells.size()); ++i) {
    const std::vector<int>& cell = r.cells[size_t(i)];
    const int material = junctions.material_of(i);
    polygon.clear();
    corner.clear();
    for (size_t k = 0; k < cell.size(); ++k) {
      polygon.push_back(cell[k]);
      corner.push_back(1);
      on_edge.clear();
      junctions.inside(cell[k], cell[(k + 1) % cell.size()], material, on_edge);
      polygon.insert(polygon.end(), on_edge.begin(), on_edge.end());
      corner.insert(corner.end(), on_edge.size(), 0);
    }
    if (polygon.size() == cell.size()) {
      out.cells.push_back(cell);
      out.patch.push_back(i);
      out.area.push_back(r.mesh.patches[size_t(i)].area);
      continue;
    }
    ++out.patches_cut;
    triangles.clear();
    triangulate(polygon, corner, triangles);
    for (const auto& t : triangles) {
      out.cells.push_back({t[0], t[1], t[2]});
      out.patch.push_back(i);
      out.area.push_back(triangle_area(r, t[0], t[1], t[2]));
    }
  }
  return out;
}

}  // namespace photometria
