#include <gtest/gtest.h>

#include "scene_builders.h"
#include "visibility/visibility.h"

using namespace photometria;

TEST(Visibility, ConvexRoomNeedsNone) {
  std::string why;
  EXPECT_TRUE(scene_needs_no_visibility(builders::unit_cube(), &why));
  EXPECT_NE(why.find("convex"), std::string::npos);
  Scene room = builders::unit_cube();
  builders::add_box(room, Vec3(0.4, 0.4, 0.4), Vec3(0.6, 0.6, 0.6));
  EXPECT_FALSE(scene_needs_no_visibility(room, &why));
  EXPECT_NE(why.find("behind"), std::string::npos);
}

// Faces meshed from one surface come one after another and share a test; a face in a parallel
// plane at another height does not.
TEST(Visibility, ConvexityIsTestedPerPlaneOfConsecutiveFaces) {
  // A street canyon: the street and two facing walls, each cut into 8 strips (x along it).
  Scene canyon;
  canyon.source = "canyon";
  const auto quad = [&](Vec3 a, Vec3 b, Vec3 c, Vec3 d) {
    const int k = static_cast<int>(canyon.vertices.size());
    canyon.vertices.insert(canyon.vertices.end(), {a, b, c, d});
    canyon.faces.push_back({{k, k + 1, k + 2, k + 3}, 0, 0, static_cast<int>(canyon.faces.size())});
  };
  for (int i = 0; i < 8; ++i) quad(Vec3(i, 0, 0), Vec3(i + 1, 0, 0), Vec3(i + 1, 2, 0), Vec3(i, 2, 0));
  for (int i = 0; i < 8; ++i) quad(Vec3(i, 0, 0), Vec3(i, 0, 2), Vec3(i + 1, 0, 2), Vec3(i + 1, 0, 0));
  for (int i = 0; i < 8; ++i) quad(Vec3(i + 1, 2, 0), Vec3(i + 1, 2, 2), Vec3(i, 2, 2), Vec3(i, 2, 0));
  canyon.materials = builders::unit_cube().materials;
  canyon.groups = {"canyon"};
  std::string why;
  EXPECT_TRUE(scene_needs_no_visibility(canyon, &why)) << why;
  // The street's last strip raised by 1 mm: the strips before it lie behind its plane.
  Scene step = canyon;
  for (int k = 28; k < 32; ++k) step.vertices[size_t(k)].z() = 1e-3;
  EXPECT_FALSE(scene_needs_no_visibility(step, &why));
  EXPECT_EQ(why.rfind("face 7 has vertex 0 behind its plane", 0), 0u) << why;
}

TEST(Visibility, SegmentsThroughABoxAreBlockedFromBothSides) {
  Scene room = builders::unit_cube();
  builders::add_box(room, Vec3(0.4, 0.4, 0.4), Vec3(0.6, 0.6, 0.6));
  const RayVisibility vis(room);
  EXPECT_TRUE(vis.blocked(Vec3(0.5, 0.5, 0.01), Vec3(0.5, 0.5, 0.99)));
  EXPECT_TRUE(vis.blocked(Vec3(0.5, 0.5, 0.99), Vec3(0.5, 0.5, 0.01)));
  EXPECT_FALSE(vis.blocked(Vec3(0.1, 0.1, 0.01), Vec3(0.1, 0.1, 0.99)));
  // End points on the room's own walls do not block themselves.
  EXPECT_FALSE(vis.blocked(Vec3(0.1, 0.1, 0.0), Vec3(0.9, 0.1, 1.0)));
}

TEST(Visibility, HalfBlockedPairIsAboutHalfAndRepeatable) {
  // Floor patch and ceiling patch of the unit cube; a thin plate covers x < 0.5 at mid height.
  Scene room = builders::unit_cube();
  builders::add_box(room, Vec3(-0.5, -0.5, 0.49), Vec3(0.5, 1.5, 0.51));
  const RayVisibility vis(room);
  const Vec3 floor[4] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  const Vec3 ceiling[4] = {{0, 0, 1}, {0, 1, 1}, {1, 1, 1}, {1, 0, 1}};
  const double v = vis.patch_to_patch(floor, 4, Vec3::UnitZ(), ceiling, 4, -Vec3::UnitZ(), 1024, 42);
  EXPECT_NEAR(v, 0.5, 0.05);
  EXPECT_EQ(v, vis.patch_to_patch(floor, 4, Vec3::UnitZ(), ceiling, 4, -Vec3::UnitZ(), 1024, 42));
  const double p = vis.point_to_patch(Vec3(0.75, 0.5, 0), Vec3::UnitZ(), ceiling, 4, -Vec3::UnitZ(), 1024, 1);
  EXPECT_GT(p, 0.5);
  EXPECT_LT(p, 1.0);
}
