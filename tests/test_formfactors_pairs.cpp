// Per-pair adaptive patch-to-patch factors against Howell's closed forms
// (tests/data/refs_public.json).
#include <gtest/gtest.h>

#include "formfactors/pair_integration.h"
#include "refs.h"

using namespace photometria;

namespace {
PairResult run_case(const std::string& id, double tol) {
  const auto& g = refs::find(id)["geometry"];
  Polygon p1 = refs::polygon(g["patch1"]["vertices"]), p2 = refs::polygon(g["patch2"]["vertices"]);
  const Vec3 n1 = refs::vec(g["patch1"]["normal"]), n2 = refs::vec(g["patch2"]["normal"]);
  if (polygon_normal(p1).dot(n1) < 0) std::reverse(p1.begin(), p1.end());
  if (polygon_normal(p2).dot(n2) < 0) std::reverse(p2.begin(), p2.end());
  return pair_form_factor(p1.data(), int(p1.size()), n1, p2.data(), int(p2.size()), n2, tol);
}
}  // namespace

TEST(PairIntegration, HowellCasesToTheRequestedTolerance) {
  for (const std::string id : {"C11_unit_squares_c1", "C11_2x1_c1", "C11_1x3_c0.5", "C14_unit", "C14_l1_w2_h0.5",
                               "C14_l1_w0.5_h2", "cube_floor_to_ceiling", "cube_floor_to_wall"}) {
    const double want = double(refs::number(refs::find(id)["value"]));
    for (double tol : {1e-4, 1e-6, 1e-8}) {
      const PairResult r = run_case(id, tol);
      EXPECT_LE(std::abs(r.form_factor - want) / want, tol) << id << " tol " << tol << " rule " << int(r.rule);
    }
  }
}

TEST(PairIntegration, SharedEdgeUsesAdaptiveAndFewEvaluations) {
  const PairResult r = run_case("C14_unit", 1e-6);
  EXPECT_EQ(r.rule, PairRule::Adaptive);
  EXPECT_LT(r.evaluations, 20000);
}

TEST(PairIntegration, FarPairUsesLowOrderGauss) {
  const Vec3 a[4] = {{0, 0, 0}, {0.1, 0, 0}, {0.1, 0.1, 0}, {0, 0.1, 0}};
  const Vec3 b[4] = {{0, 0, 5}, {0, 0.1, 5}, {0.1, 0.1, 5}, {0.1, 0, 5}};
  const PairResult r = pair_form_factor(a, 4, Vec3::UnitZ(), b, 4, -Vec3::UnitZ(), 1e-6);
  EXPECT_EQ(r.rule, PairRule::Gauss);
  EXPECT_LE(r.order, 3);
  // Far field: F ≈ A_j / (π d²).
  EXPECT_NEAR(r.form_factor, 0.01 / (M_PI * 25.0), 1e-7);
}

TEST(PairIntegration, ReceiverPartlyBehindTheSourceIsClippedNotKinked) {
  // A unit wall patch x = 1 (facing −x) crossing the plane y = 0.3 of a small source facing −y.
  const Vec3 wall[4] = {{1, 0.25, 0.25}, {1, 0.25, 0.5}, {1, 0.5, 0.5}, {1, 0.5, 0.25}};
  const Vec3 side[4] = {{0.5, 0.3, 0.4}, {0.7, 0.3, 0.4}, {0.7, 0.3, 0.45}, {0.5, 0.3, 0.45}};
  const PairResult lo = pair_form_factor(wall, 4, -Vec3::UnitX(), side, 4, -Vec3::UnitY(), 1e-5);
  const PairResult hi = pair_form_factor(wall, 4, -Vec3::UnitX(), side, 4, -Vec3::UnitY(), 1e-9);
  EXPECT_GT(lo.form_factor, 0.0);
  EXPECT_NEAR(lo.form_factor, hi.form_factor, 1e-5 * hi.form_factor);
  // Reciprocity with the reverse direction.
  const PairResult back = pair_form_factor(side, 4, -Vec3::UnitY(), wall, 4, -Vec3::UnitX(), 1e-9);
  EXPECT_NEAR(0.0625 * hi.form_factor, 0.01 * back.form_factor, 1e-8 * 0.01 * back.form_factor);
}
