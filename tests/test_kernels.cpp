// Lambert's point-to-polygon kernel against the analytic references and at its edge cases.
#include <gtest/gtest.h>

#include <cmath>

#include "kernels/lambert.h"
#include "refs.h"

using namespace photometria;

namespace {
// Required tolerance: 1e-12 relative, or 1e-15 absolute for values below 1e-3.
void expect_matches_reference(double got, long double want, const std::string& id) {
  SCOPED_TRACE(id);
  ASSERT_TRUE(std::isfinite(got));
  if (std::abs(want) < 1e-3L) EXPECT_LE(std::abs(got - want), 1e-15L) << got << " vs " << double(want);
  else EXPECT_LE(std::abs((got - want) / want), 1e-12L) << got << " vs " << double(want);
}
}  // namespace

TEST(Lambert, EveryPointPolygonReference) {
  int cases = 0;
  for (const auto& c : refs::all()["cases"]) {
    if (c["kind"] != "point_polygon") continue;
    const auto& g = c["geometry"];
    const Receiver r{refs::vec(g["receiver"]["point"]), refs::vec(g["receiver"]["normal"]).normalized()};
    expect_matches_reference(lambert_form_factor(r, refs::polygon(g["polygon"])), refs::number(c["value"]),
                             c["id"].get<std::string>());
    ++cases;
  }
  EXPECT_EQ(cases, 17);
}

TEST(Lambert, BackSideIsZero) {
  const auto& c = refs::find("pp_B3_centered_square");
  Polygon poly = refs::polygon(c["geometry"]["polygon"]);
  std::reverse(poly.begin(), poly.end());
  EXPECT_EQ(lambert_form_factor({Vec3::Zero(), Vec3::UnitZ()}, poly), 0.0);
}

TEST(Lambert, StartingVertexDoesNotMatter) {
  const auto& c = refs::find("pp_general_quad_general_receiver");
  const auto& g = c["geometry"];
  const Receiver r{refs::vec(g["receiver"]["point"]), refs::vec(g["receiver"]["normal"]).normalized()};
  Polygon poly = refs::polygon(g["polygon"]);
  const double f0 = lambert_form_factor(r, poly);
  std::rotate(poly.begin(), poly.begin() + 1, poly.end());
  EXPECT_NEAR(lambert_form_factor(r, poly), f0, 1e-15);
}

// A wall standing on the receiver plane, receiver exactly on the wall's bottom edge: seen from just in
// front, the wall fills half the hemisphere whatever its size, so the limit is exactly 1/2 and
// 1/2 − F grows linearly with the distance (refs: pp_B4_mid_edge_c1e-6 is 1/2 − 7.8e-7 at 1e-6).
TEST(Lambert, ReceiverOnEdgeIsTheLimitFromTheFront) {
  const Polygon wall = {{0, -0.5, 1}, {0, 0.5, 1}, {0, 0.5, 0}, {0, -0.5, 0}};  // front normal -x
  const double f_edge = lambert_form_factor({Vec3::Zero(), Vec3::UnitZ()}, wall);
  const double f_near = lambert_form_factor({Vec3(-1e-9, 0, 0), Vec3::UnitZ()}, wall);
  EXPECT_NEAR(f_edge, 0.5, 1e-15);
  EXPECT_NEAR(f_near, 0.5 - 7.84e-10, 1e-11);
  // From behind the wall (x > 0) the wall is invisible.
  EXPECT_EQ(lambert_form_factor({Vec3(1e-9, 0, 0), Vec3::UnitZ()}, wall), 0.0);
}

TEST(Lambert, ReceiverOnVertexIsFiniteAndMatchesTheApproachLimit) {
  const Polygon wall = {{0, 0, 1}, {0, 1, 1}, {0, 1, 0}, {0, 0, 0}};  // corner at the origin, front -x
  const Vec3 approach = Vec3(-1, 1, 0).normalized();
  const double at_vertex = lambert_form_factor({Vec3::Zero(), Vec3::UnitZ(), approach}, wall);
  const double near = lambert_form_factor({1e-10 * approach, Vec3::UnitZ()}, wall);
  EXPECT_TRUE(std::isfinite(at_vertex));
  EXPECT_NEAR(at_vertex, near, 1e-8);
  EXPECT_GT(at_vertex, 0.0);
}

TEST(Lambert, ReceiverInsideThePolygonPlaneSeesNothing) {
  const Polygon floor = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
  EXPECT_EQ(lambert_form_factor({Vec3(0.2, 0.1, 0), Vec3::UnitZ()}, floor), 0.0);  // F_ii = 0
  EXPECT_EQ(lambert_form_factor({Vec3(3, 0, 0), Vec3(-1, 0, 0)}, floor), 0.0);     // in plane, outside
}

TEST(Lambert, ClosedRoomSumsToOne) {
  // From any interior point on the floor, the five other walls of a unit cube cover the hemisphere.
  const std::vector<Polygon> walls = {{{0, 0, 1}, {0, 1, 1}, {1, 1, 1}, {1, 0, 1}},
                                      {{0, 0, 0}, {0, 0, 1}, {1, 0, 1}, {1, 0, 0}},
                                      {{1, 0, 0}, {1, 0, 1}, {1, 1, 1}, {1, 1, 0}},
                                      {{1, 1, 0}, {1, 1, 1}, {0, 1, 1}, {0, 1, 0}},
                                      {{0, 1, 0}, {0, 1, 1}, {0, 0, 1}, {0, 0, 0}}};
  for (const Vec3& p : {Vec3(0.5, 0.5, 0), Vec3(0.01, 0.3, 0), Vec3(1e-12, 1e-12, 0), Vec3(0, 0.5, 0), Vec3(0, 0, 0)}) {
    const Vec3 approach = (Vec3(0.5, 0.5, 0) - p).normalized();
    double sum = 0.0;
    for (const auto& w : walls) sum += lambert_form_factor({p, Vec3::UnitZ(), approach}, w);
    EXPECT_NEAR(sum, 1.0, 1e-14) << p.transpose();
  }
}

TEST(Lambert, DegenerateInputGivesZeroNotNaN) {
  EXPECT_EQ(lambert_form_factor({Vec3::Zero(), Vec3::UnitZ()}, Polygon{{0, 0, 1}, {1, 0, 1}}), 0.0);
  EXPECT_EQ(lambert_form_factor({Vec3::Zero(), Vec3::UnitZ()}, Polygon{{0, 0, 1}, {0, 0, 1}, {0, 0, 1}}), 0.0);
  const Polygon with_zero_edge = {{0, 1, 1}, {1, 1, 1}, {1, 1, 1}, {1, 0, 1}, {0, 0, 1}};
  EXPECT_NEAR(lambert_form_factor({Vec3::Zero(), Vec3::UnitZ()}, with_zero_edge),
              double(refs::number(refs::find("pp_B3_unit_square_corner")["value"])), 1e-15);
}
