#include <gtest/gtest.h>

#include "geometry/polygon.h"

using namespace photometria;

TEST(Polygon, AreaNormalCentroidOfASquare) {
  const Polygon sq = {{0, 0, 2}, {2, 0, 2}, {2, 2, 2}, {0, 2, 2}};
  EXPECT_DOUBLE_EQ(polygon_area(sq), 4.0);
  EXPECT_TRUE(polygon_normal(sq).isApprox(Vec3::UnitZ()));
  EXPECT_TRUE(polygon_centroid(sq).isApprox(Vec3(1, 1, 2)));
  EXPECT_EQ(planarity_deviation(sq), 0.0);
}

TEST(Polygon, CentroidOfAnLShape) {
  const Polygon l = {{0, 0, 0}, {2, 0, 0}, {2, 1, 0}, {1, 1, 0}, {1, 2, 0}, {0, 2, 0}};
  EXPECT_DOUBLE_EQ(polygon_area(l), 3.0);
  EXPECT_TRUE(polygon_centroid(l).isApprox(Vec3(5.0 / 6, 5.0 / 6, 0)));
  EXPECT_FALSE(is_convex(l));
  const auto tris = triangulate_polygon(l);
  ASSERT_EQ(tris.size(), 4u);
  double area = 0;
  for (const auto& t : tris) area += polygon_area({l[t[0]], l[t[1]], l[t[2]]});
  EXPECT_DOUBLE_EQ(area, 3.0);
}

TEST(Polygon, NonPlanarQuadIsDetected) {
  const Polygon q = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0.1}, {0, 1, 0}};
  EXPECT_GT(planarity_deviation(q), 0.01);
}

TEST(Polygon, ClipKeepsVerticesOnThePlaneAndCutsCrossingEdges) {
  const Polygon sq = {{-1, 0, -1}, {1, 0, -1}, {1, 0, 1}, {-1, 0, 1}};
  Polygon out;
  clip_to_halfspace(sq.data(), 4, Vec3::UnitZ(), out);
  ASSERT_EQ(out.size(), 4u);
  for (const Vec3& v : out) EXPECT_GE(v.z(), 0.0);
  EXPECT_DOUBLE_EQ(polygon_area(out), 2.0);
  const Polygon touching = {{0, 0, 0}, {1, 0, 1}, {-1, 0, 1}};
  clip_to_halfspace(touching.data(), 3, Vec3::UnitZ(), out);
  EXPECT_EQ(out.size(), 3u);
  const Polygon below = {{0, 0, -1}, {1, 0, -1}, {0, 1, -1}};
  clip_to_halfspace(below.data(), 3, Vec3::UnitZ(), out);
  EXPECT_TRUE(out.empty());
}
