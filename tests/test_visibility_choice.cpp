// The visibility decision (visibility/choice.h): auto picks from the estimated cost of each mode.
#include <gtest/gtest.h>

#include <cmath>

#include "scene_builders.h"
#include "util/error.h"
#include "visibility/choice.h"

namespace {

using namespace photometria;

TEST(VisibilityChoice, ConvexEnclosureNeedsNone) {
  EXPECT_EQ(choose_visibility(builders::unit_cube(), VisibilityMode::Auto).mode, VisibilityMode::None);
}

TEST(VisibilityChoice, RequestedModesAreKept) {
  Scene s = builders::unit_cube();
  builders::add_box(s, {0.4, 0.4, 0.4}, {0.6, 0.6, 0.6});
  EXPECT_EQ(choose_visibility(s, VisibilityMode::Rays).mode, VisibilityMode::Rays);
  EXPECT_EQ(choose_visibility(s, VisibilityMode::Exact).mode, VisibilityMode::Exact);
  EXPECT_EQ(choose_visibility(s, VisibilityMode::None).mode, VisibilityMode::None);
}

TEST(VisibilityChoice, FewOccludersPerShaftClip) {
  // A room with one box: whatever the face count, shafts hold a few occluders.
  Scene s = builders::unit_cube();
  builders::add_box(s, {0.4, 0.4, 0.0}, {0.6, 0.6, 0.5});
  const VisibilityChoice c = choose_visibility(s, VisibilityMode::Auto);
  EXPECT_EQ(c.mode, VisibilityMode::Exact);
  EXPECT_NE(c.reason.find("occluders per occluded point shaft"), std::string::npos) << c.reason;
  const ShaftCuller culler(s);
  const VisibilityCostEstimate e = estimate_visibility_cost(culler, kDefaultRays);
  EXPECT_GT(e.sampled_pairs, 0);
  EXPECT_GT(e.occluded_pairs, 0);
  EXPECT_GE(e.mean_occluders, 1.0);
  EXPECT_LT(e.exact_seconds, e.rays_seconds);
}

TEST(VisibilityChoice, ManyOccludersPerShaftCastRays) {
  // A cloud of 4,000 small tilted triangles in the middle of the room (a scanned object's facets, none
  // coplanar with another): a shaft across the room meets dozens of them.
  Scene s = builders::unit_cube();
  for (int a = 0; a < 20; ++a)
    for (int b = 0; b < 20; ++b)
      for (int c = 0; c < 10; ++c) {
        const Vec3 o(0.2 + 0.03 * a, 0.2 + 0.03 * b, 0.2 + 0.06 * c);
        const double t = 0.3 * (a + 2 * b + 3 * c);  // a different tilt for every triangle
        const int v = static_cast<int>(s.vertices.size());
        s.vertices.push_back(o);
        s.vertices.push_back(o + Vec3(0.04, 0.01 * std::sin(t), 0.01 * std::cos(t)));
        s.vertices.push_back(o + Vec3(0.01 * std::cos(t), 0.04, 0.01 * std::sin(t)));
        s.faces.push_back({{v, v + 1, v + 2}, 0, 0, static_cast<int>(s.faces.size())});
      }
  Scene box = builders::unit_cube();
  builders::add_box(box, {0.4, 0.4, 0.0}, {0.6, 0.6, 0.5});
  const VisibilityCostEstimate cloud_cost = estimate_visibility_cost(ShaftCuller(s), kDefaultRays);
  const VisibilityCostEstimate box_cost = estimate_visibility_cost(ShaftCuller(box), kDefaultRays);
  EXPECT_GT(cloud_cost.mean_occluders, 10 * box_cost.mean_occluders);
  // The clipping cost grows faster than the occluder count (each cuts the fragments the next clips).
  EXPECT_GT(cloud_cost.exact_seconds / cloud_cost.mean_occluders, 5 * box_cost.exact_seconds / box_cost.mean_occluders);
  // With 64 rays per point, rays are the cheaper for the cloud, clipping for the box.
  const VisibilityChoice c = choose_visibility(s, VisibilityMode::Auto, 64);
  EXPECT_EQ(c.mode, VisibilityMode::Rays) << c.reason;
  EXPECT_NE(c.reason.find("rays"), std::string::npos);
  EXPECT_EQ(choose_visibility(box, VisibilityMode::Auto, 64).mode, VisibilityMode::Exact);
  // Very few rays make them the choice even for a box.
  EXPECT_EQ(choose_visibility(box, VisibilityMode::Auto, 1).mode, VisibilityMode::Rays);
}

TEST(VisibilityChoice, AClosedObjectCountsOnlyTheOccludersFacingThePoint) {
  // A scanned object of 960 triangles in the room: from a point outside it, only the occluders
  // facing the point can shadow it (ShaftCuller::drop_hidden_occluders). The same surface with
  // one triangle missing is no solid, and every triangle in a shaft counts.
  Scene closed = builders::unit_cube();
  builders::add_bumpy_sphere(closed, {0.5, 0.5, 0.45}, 0.25, 20, 24, 0.1);
  Scene open = closed;
  open.faces.pop_back();
  const ShaftCuller closed_culler(closed), open_culler(open);
  ASSERT_EQ(closed_culler.closed_solid_count(), 1);
  ASSERT_EQ(open_culler.closed_solid_count(), 0);
  const VisibilityCostEstimate c = estimate_visibility_cost(closed_culler, kDefaultRays);
  const VisibilityCostEstimate o = estimate_visibility_cost(open_culler, kDefaultRays);
  EXPECT_GT(c.occluded_pairs, 0);
  EXPECT_LT(c.mean_occluders, 0.75 * o.mean_occluders);
  EXPECT_LT(c.exact_seconds, o.exact_seconds);
}

}  // namespace

TEST(VisibilityChoice, RayCountIsAutoOrAPositiveInteger) {
  EXPECT_EQ(parse_ray_count("auto"), kAdaptiveRays);
  EXPECT_EQ(parse_ray_count("576"), 576);
  EXPECT_EQ(parse_ray_count("16777216"), 1 << 24);
  for (const std::string bad : {"0", "-1", "16777217", "1.5", "", "Auto", "64x"}) {
    try {
      parse_ray_count(bad);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()).rfind("--rays: " + bad + " is not auto", 0), 0u) << e.what();
    }
  }
  EXPECT_EQ(ray_sampling_name(64, {}), "64 rays per point and patch");
  EXPECT_EQ(ray_sampling_name(kAdaptiveRays, {1e-3, 1024}),
            "adaptive, 8² to 32² rays per point and patch, to a relative error of 0.001");
  EXPECT_EQ(ray_sampling_name(kAdaptiveRays, {1e-3, 4096}).find("8² to 64²"), 10u);
  EXPECT_EQ(ray_sampling_for(0.0).tolerance, RaySampling{}.tolerance);
  EXPECT_EQ(ray_sampling_for(1e-5).tolerance, 1e-5);
}
