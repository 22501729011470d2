// ShaftCuller::blocks_every_segment: one occluder that blocks every segment between two polygons.
#include <gtest/gtest.h>

#include "scene_builders.h"
#include "visibility/visibility.h"

namespace {

using namespace photometria;

// The unit cube with a horizontal plate (a table top, faces 6..11 of a thin box) at z = 0.5
// covering [0.2, 0.8]².
Scene cube_with_plate() {
  Scene s = builders::unit_cube();
  builders::add_box(s, {0.2, 0.2, 0.49}, {0.8, 0.8, 0.5});
  return s;
}

int occluder_of(const ShaftCuller& c, int face) { return c.occluder_of_face(face); }

TEST(BlocksEverySegment, PlateBetweenSmallFloorAndCeilingSquares) {
  const Scene s = cube_with_plate();
  const ShaftCuller culler(s);
  const Vec3 floor[4] = {{0.4, 0.4, 0}, {0.6, 0.4, 0}, {0.6, 0.6, 0}, {0.4, 0.6, 0}};
  const Vec3 ceiling[4] = {{0.4, 0.4, 1}, {0.4, 0.6, 1}, {0.6, 0.6, 1}, {0.6, 0.4, 1}};
  const int top = occluder_of(culler, 7), bottom = occluder_of(culler, 6);  // z = hi and z = lo of the plate
  EXPECT_TRUE(culler.blocks_every_segment(floor, 4, ceiling, 4, top));
  EXPECT_TRUE(culler.blocks_every_segment(ceiling, 4, floor, 4, bottom));
  // A plate side face (vertical) blocks nothing of it alone.
  EXPECT_FALSE(culler.blocks_every_segment(floor, 4, ceiling, 4, occluder_of(culler, 8)));
}

TEST(BlocksEverySegment, SegmentsPastThePlateEdgeAreNotAllBlocked) {
  const Scene s = cube_with_plate();
  const ShaftCuller culler(s);
  const int top = occluder_of(culler, 7);
  // The ceiling square reaches past the plate's edge seen from the floor square: the segment from
  // the floor square's corner (0.6, 0.6) to the ceiling's (1, 1) crosses z = 0.5 at (0.8, 0.8), the
  // plate's corner; farther out it misses.
  const Vec3 floor[4] = {{0.4, 0.4, 0}, {0.6, 0.4, 0}, {0.6, 0.6, 0}, {0.4, 0.6, 0}};
  const Vec3 wide[4] = {{0.4, 0.4, 1}, {0.4, 1.0, 1}, {1.0, 1.0, 1}, {1.0, 0.4, 1}};
  EXPECT_FALSE(culler.blocks_every_segment(floor, 4, wide, 4, top));
  const Vec3 inside[4] = {{0.4, 0.4, 1}, {0.4, 0.9, 1}, {0.9, 0.9, 1}, {0.9, 0.4, 1}};
  // (0.6, 0.6, 0) to (0.9, 0.9, 1) crosses at (0.75, 0.75): inside, as every other crossing.
  EXPECT_TRUE(culler.blocks_every_segment(floor, 4, inside, 4, top));
}

TEST(BlocksEverySegment, PolygonsOnOneSideOrTouchingThePlaneAreNotBlocked) {
  const Scene s = cube_with_plate();
  const ShaftCuller culler(s);
  const int top = occluder_of(culler, 7);
  const Vec3 floor[4] = {{0.4, 0.4, 0}, {0.6, 0.4, 0}, {0.6, 0.6, 0}, {0.4, 0.6, 0}};
  const Vec3 low[4] = {{0.4, 0.4, 0.3}, {0.4, 0.6, 0.3}, {0.6, 0.6, 0.3}, {0.6, 0.4, 0.3}};
  EXPECT_FALSE(culler.blocks_every_segment(floor, 4, low, 4, top));
  // A polygon with a corner on the plate's plane: that corner's segments graze the plate.
  const Vec3 touching[3] = {{0.5, 0.5, 0.5}, {0.4, 0.6, 1}, {0.6, 0.6, 1}};
  EXPECT_FALSE(culler.blocks_every_segment(floor, 4, touching, 3, top));
}

}  // namespace
