#include <gtest/gtest.h>

#include <map>

#include "patching/patching.h"
#include "scene_builders.h"

using namespace photometria;

namespace {
// Every interior patch edge must be shared by exactly two patches in a closed, conforming mesh.
std::map<std::pair<int, int>, int> edge_use(const PatchMesh& m) {
  std::map<std::pair<int, int>, int> use;
  for (const Patch& p : m.patches)
    for (int k = 0; k < p.corner_count; ++k) {
      const int a = p.corners[k], b = p.corners[(k + 1) % p.corner_count];
      ++use[{std::min(a, b), std::max(a, b)}];
    }
  return use;
}
}  // namespace

TEST(Patching, CubeGridsAreConformingAndRespectMaxEdge) {
  const Scene cube = builders::unit_cube();
  const PatchMesh m = subdivide(cube, {0.3, 0.0});
  EXPECT_EQ(m.size(), 6 * 4 * 4);  // ceil(1/0.3) = 4 per edge
  for (const auto& [edge, count] : edge_use(m)) EXPECT_EQ(count, 2);
  double area = 0;
  for (const Patch& p : m.patches) {
    area += p.area;
    for (int k = 0; k < 4; ++k) EXPECT_LE((m.points[p.corners[k]] - m.points[p.corners[(k + 1) % 4]]).norm(), 0.3 + 1e-12);
  }
  EXPECT_NEAR(area, 6.0, 1e-12);
  EXPECT_EQ(m.points.size(), 6u * 16 + 2);  // V = E − F + 2 on a sphere: closed and welded
}

TEST(Patching, MaxAreaRefinesToo) {
  const PatchMesh m = subdivide(builders::unit_cube(), {0.0, 0.05});
  for (const Patch& p : m.patches) EXPECT_LE(p.area, 0.05 + 1e-12);
  EXPECT_EQ(m.size(), 6 * 5 * 5);
}

TEST(Patching, TrianglesSplitIntoSimilarTrianglesSharingEdges) {
  Scene s;
  s.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  s.faces = {{{0, 1, 2}, 0, 0, 0}, {{1, 3, 2}, 0, 0, 1}};
  s.materials = {Material{}};
  s.groups = {"g"};
  const PatchMesh m = subdivide(s, {0.26, 0.0});  // the diagonal (1.41) needs 6 → all edges 6
  EXPECT_EQ(m.size(), 2 * 36);
  int boundary = 0;
  for (const auto& [edge, count] : edge_use(m)) {
    EXPECT_LE(count, 2);
    boundary += count == 1;
  }
  EXPECT_EQ(boundary, 4 * 6);
  for (const Patch& p : m.patches) EXPECT_NEAR(p.area, 0.5 / 36, 1e-15);
}

TEST(Patching, NormalsFollowTheFace) {
  const Scene cube = builders::unit_cube();
  const PatchMesh m = subdivide(cube, {0.5, 0.0});
  for (const Patch& p : m.patches) {
    const Vec3 n = polygon_normal(m.polygon(static_cast<int>(&p - m.patches.data())));
    EXPECT_TRUE(n.isApprox(p.normal, 1e-12));
    EXPECT_GT(p.normal.dot(Vec3(0.5, 0.5, 0.5) - p.centroid), 0.0);  // inward
  }
}
