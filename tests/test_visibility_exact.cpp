// Exact visibility (Nishita & Nakamae 1985 in 3-D): analytic occluded configurations whose
// answers come from superposition of Howell's closed form (visibility_configs.h), not from the
// Lambert kernel the implementation uses.
#include <gtest/gtest.h>

#include <numeric>

#include "kernels/lambert.h"
#include "visibility/visibility.h"
#include "visibility_configs.h"

using namespace photometria;
using namespace vis_configs;

namespace {

std::vector<int> all(const std::vector<Polygon>& faces) {
  std::vector<int> w(faces.size());
  std::iota(w.begin(), w.end(), 0);
  return w;
}

double exact(const Polygon& source, const std::vector<Polygon>& occluders, const Vec3& p = Vec3::Zero(),
             const Vec3& n = Vec3::UnitZ()) {
  return exact_visible_form_factor(Receiver{p, n}, source.data(), int(source.size()), occluders, all(occluders));
}

}  // namespace

// Example: a square source above the receiver, a smaller parallel square blocker
// halfway: visible = source minus the blocker's shadow on the source plane (scaled by 2).
TEST(VisibilityExact, CentredParallelBlocker) {
  const Polygon source = rect_poly(-1, 1, -1, 1, 2);
  for (bool down : {true, false}) {  // occluders are two-sided
    const double f = exact(source, {rect_poly(-0.25, 0.25, -0.25, 0.25, 1, down)});
    const double ref = rect(-1, 1, -1, 1, 2) - rect(-0.5, 0.5, -0.5, 0.5, 2);
    EXPECT_NEAR(f, ref, 1e-12 * ref);
  }
}

TEST(VisibilityExact, OffCentreBlockerShadowCutBySourceEdge) {
  const Polygon source = rect_poly(-1, 1, -1, 1, 2);
  // Shadow [0.2, 1.2] × [-0.4, 0.6] reaches past the source's edge x = 1.
  const double f = exact(source, {rect_poly(0.1, 0.6, -0.2, 0.3, 1)});
  const double ref = rect(-1, 1, -1, 1, 2) - rect(0.2, 1, -0.4, 0.6, 2);
  EXPECT_NEAR(f, ref, 1e-12 * ref);
}

TEST(VisibilityExact, OverlappingBlockersCountTheirUnionOnce) {
  const Polygon source = rect_poly(-1, 1, -1, 1, 2);
  // Shadows S1 = [0.2, 1] × [-0.4, 0.6] (z = 1, ×2) and S2 = [0.8, 1] × [-0.4, 1] (z = 0.5, ×4).
  const std::vector<Polygon> blockers = {rect_poly(0.1, 0.6, -0.2, 0.3, 1), rect_poly(0.2, 0.5, -0.1, 0.4, 0.5, false)};
  const double ref =
      rect(-1, 1, -1, 1, 2) - rect(0.2, 1, -0.4, 0.6, 2) - rect(0.8, 1, -0.4, 1, 2) + rect(0.8, 1, -0.4, 0.6, 2);
  EXPECT_NEAR(exact(source, blockers), ref, 1e-12 * ref);
  // Blockers behind the source or behind the receiver change nothing.
  const double unoccluded = rect(-1, 1, -1, 1, 2);
  EXPECT_NEAR(exact(source, {rect_poly(-5, 5, -5, 5, 3), rect_poly(-5, 5, -5, 5, -1)}), unoccluded, 1e-12 * unoccluded);
  // A receiver away from the axis: translate everything (the reference is translation-invariant).
  const Vec3 shift(0.3, -0.7, 0.2);
  Polygon s = source;
  std::vector<Polygon> b = blockers;
  for (Vec3& v : s) v += shift;
  for (Polygon& p : b)
    for (Vec3& v : p) v += shift;
  EXPECT_NEAR(exact(s, b, shift), ref, 1e-12 * ref);
}

// A plate standing on the receiver's plane (z = 0): image-plane projection of its bottom edge
// would go to infinity; wedges in 3-D do not care. Its shadow on the source plane z = 2 is
// X >= 2 (|Y| <= 40 X covers the source), so the visible part is [-1, 2] × [-1, 1].
TEST(VisibilityExact, BlockerTouchingTheReceiverPlane) {
  const Polygon source = rect_poly(-1, 3, -1, 1, 2);
  const double ref = rect(-1, 2, -1, 1, 2);
  EXPECT_NEAR(exact(source, {wall_x(0.5, -10, 10, 0, 0.5)}), ref, 1e-12 * ref);
  // The same as a closed box standing on the floor (five more faces, one of them in z = 0).
  const double x1 = 0.5, x2 = 1.5, y1 = -10, y2 = 10, h = 0.5;
  std::vector<Polygon> box = {wall_x(x1, y1, y2, 0, h),
                              rect_poly(x1, x2, y1, y2, h, false),
                              rect_poly(x1, x2, y1, y2, 0),
                              {{x2, y1, 0}, {x2, y2, 0}, {x2, y2, h}, {x2, y1, h}},
                              {{x1, y1, 0}, {x2, y1, 0}, {x2, y1, h}, {x1, y1, h}},
                              {{x1, y2, 0}, {x1, y2, h}, {x2, y2, h}, {x2, y2, 0}}};
  EXPECT_NEAR(exact(source, box), ref, 1e-12 * ref);
  // The receiver point on the box's bottom edge line (in the plane x = 0.5 of its side face): the
  // side is seen edge-on, the top face hides X >= 0.5·2/0.5... i.e. everything beyond x = 0.5.
  const Vec3 p(0.5, 0, 0);
  const double ref_edge = rect(-1.5, 0, -1, 1, 2);  // source [-1, 3] seen from x = 0.5: [-1.5, 2.5] → visible x < 0
  EXPECT_NEAR(exact(source, box, p), ref_edge, 1e-12 * ref_edge);
}

// A blocker in the source's own plane cannot hide it: segments reach that plane only at their
// end point on the source. Adjacent and overlapping coplanar faces leave F unchanged.
TEST(VisibilityExact, BlockerCoplanarWithTheSource) {
  const Polygon source = rect_poly(-1, 1, -1, 1, 2);
  const double unoccluded = lambert_form_factor(Receiver{Vec3::Zero(), Vec3::UnitZ()}, source);
  EXPECT_EQ(exact(source, {rect_poly(1, 2, -1, 1, 2), rect_poly(0, 0.5, 0, 0.5, 2, false)}), unoccluded);
}

// The image of a receiver point's whole hemisphere: in a closed cube with a box inside, the
// visible factors from one point to every face sum to 1 (the fragments tile the hemisphere).
TEST(VisibilityExact, VisibleFactorsFromAPointTileItsHemisphere) {
  std::vector<Polygon> faces = {
      {{0, 0, 1}, {0, 1, 1}, {1, 1, 1}, {1, 0, 1}},  // ceiling, facing down
      {{0, 0, 0}, {0, 0, 1}, {1, 0, 1}, {1, 0, 0}},  // y = 0, facing +y
      {{0, 1, 0}, {1, 1, 0}, {1, 1, 1}, {0, 1, 1}},  // y = 1, facing -y
      {{0, 0, 0}, {0, 1, 0}, {0, 1, 1}, {0, 0, 1}},  // x = 0, facing +x
      {{1, 0, 0}, {1, 0, 1}, {1, 1, 1}, {1, 1, 0}},  // x = 1, facing -x
  };
  const double lo = 0.4, hi = 0.7;  // box [0.4, 0.7]^2 × [0.2, 0.5], outward faces
  const std::vector<Polygon> box = {rect_poly(lo, hi, lo, hi, 0.2),
                                    rect_poly(lo, hi, lo, hi, 0.5, false),
                                    {{lo, lo, 0.2}, {hi, lo, 0.2}, {hi, lo, 0.5}, {lo, lo, 0.5}},
                                    {{lo, hi, 0.2}, {lo, hi, 0.5}, {hi, hi, 0.5}, {hi, hi, 0.2}},
                                    {{lo, lo, 0.2}, {lo, lo, 0.5}, {lo, hi, 0.5}, {lo, hi, 0.2}},
                                    {{hi, lo, 0.2}, {hi, hi, 0.2}, {hi, hi, 0.5}, {hi, lo, 0.5}}};
  faces.insert(faces.end(), box.begin(), box.end());
  for (const Vec3& p : {Vec3(0.3, 0.35, 0), Vec3(0.55, 0.55, 0), Vec3(0.9, 0.1, 0)}) {
    double sum = 0.0;
    for (const Polygon& f : faces) sum += exact(f, faces, p);
    EXPECT_NEAR(sum, 1.0, 1e-12) << p.transpose();
  }
}
