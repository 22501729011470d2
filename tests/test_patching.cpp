#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "patching/patching.h"
#include "scene_builders.h"
#include "util/error.h"

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
    for (int k = 0; k < 4; ++k)
      EXPECT_LE((m.points[p.corners[k]] - m.points[p.corners[(k + 1) % 4]]).norm(), 0.3 + 1e-12);
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

// ----- counting without building ------------------------------------------------------------------

namespace {

// The unit cube's floor and ceiling split into triangles (a mesh of quads and triangles), with
// an obstruction-only box (no patches) inside.
Scene mixed_scene() {
  Scene s = builders::unit_cube();
  s.faces[0].vertices = {0, 1, 2};
  s.faces.push_back({{0, 2, 3}, 0, 0, 6});
  s.faces[1].vertices = {4, 7, 6};
  s.faces.push_back({{4, 6, 5}, 0, 0, 7});
  builders::add_box(s, {0.4, 0.4, 0.0}, {0.6, 0.6, 0.3});
  for (size_t f = s.faces.size() - 6; f < s.faces.size(); ++f) s.faces[f].obstruction_only = true;
  return s;
}

}  // namespace

// count_patches must say exactly what subdivide() makes: patches, points, per-face grids.
TEST(Patching, CountPatchesIsWhatSubdivideMakes) {
  const Scene scenes[] = {builders::unit_cube(), mixed_scene()};
  const PatchingOptions settings[] = {{0.0, 0.0}, {0.3, 0.0}, {0.07, 0.0}, {0.0, 0.01}, {0.25, 0.003}};
  for (const Scene& scene : scenes)
    for (const PatchingOptions& o : settings) {
      const PatchMesh m = subdivide(scene, o);
      const PatchGrid g = count_patches(scene, o);
      EXPECT_EQ(g.patches, double(m.size())) << o.max_edge << " " << o.max_area;
      EXPECT_EQ(g.points, double(m.points.size())) << o.max_edge << " " << o.max_area;
      EXPECT_TRUE(g.fits_int());
      double from_faces = 0;
      for (const auto& nm : g.segments) from_faces += nm[0] * nm[1];
      EXPECT_EQ(from_faces, g.patches);
    }
}

// A typo in --max-edge is counted at once, without overflow, as far more than a mesh can index.
TEST(Patching, HugeCountsAreCountedNotBuilt) {
  const Scene cube = builders::unit_cube();
  const PatchGrid g = count_patches(cube, {1e-6, 0.0});
  EXPECT_EQ(g.patches, 6e12);
  EXPECT_FALSE(g.fits_int());
  EXPECT_GT(count_patches(cube, {1e-300, 0.0}).patches, 1e20);  // clamped segments, still finite
  EXPECT_TRUE(std::isfinite(count_patches(cube, {1e-300, 0.0}).patches));
  EXPECT_THROW(subdivide(cube, {1e-6, 0.0}), Error);
}

// The patches computed one at a time are the mesh's patches, corner for corner.
TEST(Patching, ImplicitPatchesAreTheMeshPatches) {
  const Scene scene = mixed_scene();
  for (const PatchingOptions& o :
       {PatchingOptions{0.3, 0.0}, PatchingOptions{0.09, 0.0}, PatchingOptions{0.0, 0.004}}) {
    const PatchMesh m = subdivide(scene, o);
    const PatchGrid g = count_patches(scene, o);
    const ImplicitPatches implicit(scene, g);
    ASSERT_EQ(implicit.size(), m.size());
    for (int i = 0; i < m.size(); ++i) {
      const ImplicitPatch p = implicit[i];
      ASSERT_EQ(p.face, m.patches[i].face) << i;
      ASSERT_EQ(p.corner_count, m.patches[i].corner_count) << i;
      Vec3 c[4];
      m.polygon(i, c);
      for (int k = 0; k < p.corner_count; ++k) EXPECT_LT((p.corners[k] - c[k]).norm(), 1e-14) << i << " " << k;
    }
  }
}
