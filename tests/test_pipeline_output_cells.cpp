// The written cells (src/pipeline/output_cells.h): patches cut into triangles at T-junctions, so
// that no output point of the same surface lies inside a cell's edge and the point arrays a
// viewer interpolates are continuous.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>
#include <string>

#include "pipeline/output_cells.h"
#include "pipeline/solve.h"
#include "scene/scene.h"

using namespace photometria;

namespace {

// Points of `r` (other than the cell's own) of the cell's material and normal lying inside one
// of its edges, found by brute force: distance to the segment within 1e-9 of its length, strictly
// between its ends.
int points_inside_edges(const SolveResult& r, const Scene& scene, const OutputCells& cells, size_t c) {
  const std::vector<int>& cell = cells.cells[c];
  const int material = scene.faces[size_t(r.mesh.patches[size_t(cells.patch[c])].face)].material;
  int found = 0;
  for (size_t k = 0; k < cell.size(); ++k) {
    const OutputPoint &a = r.points[size_t(cell[k])], &b = r.points[size_t(cell[(k + 1) % cell.size()])];
    const Vec3 edge = b.position - a.position;
    const double length = edge.norm();
    for (const OutputPoint& p : r.points) {
      if (p.material != material || p.normal.dot(a.normal) < 1.0 - 1e-12) continue;
      const double t = (p.position - a.position).dot(edge) / (length * length);
      if (t <= 1e-9 || t >= 1.0 - 1e-9) continue;
      if ((a.position + t * edge - p.position).norm() <= 1e-9 * length) ++found;
    }
  }
  return found;
}

// A flat square patch [0,2]² beside four squares of 0.5 along its edge x = 2 (three corners of
// theirs inside that edge, one of them two halvings deep), and a tilted panel of its own material
// whose corner lies at the midpoint of the square's edge y = 0, seen from behind the square's
// plane: not a junction of the square's.
struct HandMadeResult {
  Scene scene;
  SolveResult r;
  HandMadeResult() {
    scene.faces.resize(6);
    auto point = [&](double x, double y, double z, const Vec3& n) {
      r.points.push_back({Vec3(x, y, z), n, Vec3::Zero(), 0});
      r.mesh.points.push_back(Vec3(x, y, z));
      return int(r.points.size()) - 1;
    };
    const Vec3 up(0, 0, 1);
    auto patch = [&](std::vector<int> corners, int face) {
      Patch p;
      p.corner_count = int(corners.size());
      for (size_t k = 0; k < corners.size(); ++k) p.corners[k] = corners[k];
      p.face = face;
      const Vec3 &a = r.mesh.points[size_t(corners[0])], &b = r.mesh.points[size_t(corners[1])],
                 &c = r.mesh.points[size_t(corners[2])];
      p.normal = (b - a).cross(c - a).normalized();
      p.area = (b - a).cross(c - a).norm() * (corners.size() == 4 ? 1.0 : 0.5);
      r.mesh.patches.push_back(p);
      r.cells.push_back(corners);
    };
    const int s0 = point(0, 0, 0, up), s1 = point(2, 0, 0, up), s2 = point(2, 2, 0, up), s3 = point(0, 2, 0, up);
    patch({s0, s1, s2, s3}, 0);
    int below = s1;
    for (int k = 1; k <= 4; ++k) {
      const int on_edge = k < 4 ? point(2, 0.5 * k, 0, up) : s2;
      const int outer_below = point(2.5, 0.5 * (k - 1), 0, up);
      const int outer_above = k < 4 ? point(2.5, 0.5 * k, 0, up) : point(2.5, 2, 0, up);
      patch({below, outer_below, outer_above, on_edge}, k);
      below = on_edge;
    }
    const Vec3 tilted = Vec3(0, -1, 1).normalized();
    const int t0 = point(1, 0, 0, tilted), t1 = point(1, -1, -1, tilted), t2 = point(1.5, -1, -1, tilted);
    patch({t0, t1, t2}, 5);
  }
};

}  // namespace

TEST(OutputCells, PatchesAreCutAtTheCornersInsideTheirEdges) {
  const HandMadeResult h;
  const OutputCells cells = conforming_cells(h.scene, h.r);
  EXPECT_EQ(cells.patches_cut, 1);
  // The square (7 points around it: 4 corners and 3 inside one edge) in 5 triangles; the small
  // squares and the tilted panel as they were.
  ASSERT_EQ(cells.cells.size(), 5u + 4u + 1u);
  double square_area = 0.0;
  std::set<int> square_points;
  for (size_t c = 0; c < cells.cells.size(); ++c) {
    EXPECT_EQ(points_inside_edges(h.r, h.scene, cells, c), 0) << "cell " << c;
    if (cells.patch[c] != 0) {
      EXPECT_EQ(cells.cells[c], h.r.cells[size_t(cells.patch[c])]);
      EXPECT_EQ(cells.area[c], h.r.mesh.patches[size_t(cells.patch[c])].area);
      continue;
    }
    ASSERT_EQ(cells.cells[c].size(), 3u);
    const Vec3 &a = h.r.points[size_t(cells.cells[c][0])].position, &b = h.r.points[size_t(cells.cells[c][1])].position,
               &d = h.r.points[size_t(cells.cells[c][2])].position;
    const Vec3 n = (b - a).cross(d - a);
    EXPECT_GT(n.z(), 1e-9) << "cell " << c << ": degenerate or turned over";
    EXPECT_NEAR(cells.area[c], 0.5 * n.norm(), 1e-15);
    square_area += cells.area[c];
    square_points.insert(cells.cells[c].begin(), cells.cells[c].end());
  }
  EXPECT_NEAR(square_area, 4.0, 1e-14);
  EXPECT_EQ(square_points.size(), 7u);  // the tilted panel's corner at (1, 0, 0) is not one of them
  // Without the cut, the brute-force check sees the three corners inside the square's edge.
  OutputCells uncut;
  uncut.cells = h.r.cells;
  for (int i = 0; i < h.r.mesh.size(); ++i) uncut.patch.push_back(i);
  EXPECT_EQ(points_inside_edges(h.r, h.scene, uncut, 0), 3);
}

// The hierarchical method's leaves on the Cornell box: patches of different sizes meet, and once
// cut no point of a surface lies inside an edge of that surface's cells; the pieces cover their
// patches' area exactly.
TEST(OutputCells, HierarchicalLeavesLeaveNoTJunction) {
  const Scene scene = load_scene(std::string(PHOTOMETRIA_SOURCE_DIR) + "/meshes/cornell_box.obj");
  SolveOptions opt;
  opt.method = SolveMethod::Hierarchical;
  opt.hierarchical_error = 0.3;
  const SolveResult r = solve_scene(scene, opt);
  const OutputCells cells = conforming_cells(scene, r);
  EXPECT_GT(cells.patches_cut, 0);
  EXPECT_GT(cells.cells.size(), size_t(r.mesh.size()));
  std::map<int, double> area;
  for (size_t c = 0; c < cells.cells.size(); ++c) {
    area[cells.patch[c]] += cells.area[c];
    ASSERT_EQ(points_inside_edges(r, scene, cells, c), 0) << "cell " << c << " of patch " << cells.patch[c];
  }
  ASSERT_EQ(area.size(), size_t(r.mesh.size()));
  for (const auto& [patch, a] : area) EXPECT_NEAR(a, r.mesh.patches[size_t(patch)].area, 1e-12) << patch;
}
