// Occluded pairs integrated to a tolerance, a row at a time (formfactors/occluded_row.h): against
// brute-force receiver sums of the exact visible factor, and the row sums of a closed room with an
// object in it.
#include <gtest/gtest.h>

#include <cmath>

#include "formfactors/formfactors.h"
#include "formfactors/occluded_row.h"
#include "formfactors/pair_integration.h"
#include "kernels/lambert.h"
#include "patching/patching.h"
#include "scene_builders.h"
#include "visibility/visibility.h"

namespace {

using namespace photometria;

// Faces 0..5: the unit cube (inward), then the outward faces of a box inside it.
Scene cube_with_box(const Vec3& lo, const Vec3& hi) {
  Scene s = builders::unit_cube(0.5, 0.0);
  builders::add_box(s, lo, hi);
  return s;
}

// The unit cube (faces 0..5, the floor 0) with a box [lo, hi] standing on the floor, in patches of
// edge at most 0.5 (the floor in four quarters).
struct BoxOnFloor {
  Scene scene;
  PatchMesh mesh;
  BoxOnFloor(const Vec3& lo, const Vec3& hi) : scene(cube_with_box(lo, hi)) {
    PatchingOptions patching;
    patching.max_edge = 0.5;
    mesh = subdivide(scene, patching);
  }
  // The floor quarter on the high (or low) side of x = 0.5 and of y = 0.5.
  int floor_quarter(bool high_x, bool high_y) const {
    for (int k = 0; k < mesh.size(); ++k) {
      const Patch& q = mesh.patches[size_t(k)];
      if (q.face == 0 && (q.centroid.x() > 0.5) == high_x && (q.centroid.y() > 0.5) == high_y) return k;
    }
    return -1;
  }
};

struct Pair {
  int i, j;
  Vec3 r[4], s[4];
  int rn, sn;
  Vec3 rnormal, snormal;
  double area;
  Polygon rpart, spart;
  std::vector<int> occluders;
};

Pair pair_of(const PatchMesh& mesh, const Visibility& vis, int i, int j) {
  Pair p;
  p.i = i;
  p.j = j;
  mesh.polygon(i, p.r);
  mesh.polygon(j, p.s);
  p.rn = mesh.patches[size_t(i)].corner_count;
  p.sn = mesh.patches[size_t(j)].corner_count;
  p.rnormal = mesh.patches[size_t(i)].normal;
  p.snormal = mesh.patches[size_t(j)].normal;
  p.area = mesh.patches[size_t(i)].area;
  clip_to_halfspace_at(p.r, p.rn, p.s[0], p.snormal, p.rpart);
  clip_to_halfspace_at(p.s, p.sn, p.r[0], p.rnormal, p.spart);
  vis.culler().occluders(p.r, p.rn, p.s, p.sn, p.occluders);
  return p;
}

double unoccluded(const Pair& p) {
  return pair_form_factor(p.r, p.rn, p.rnormal, p.s, p.sn, p.snormal, 1e-12).form_factor;
}

struct PairValue {
  double form_factor = 0.0;
  OccludedRowResult row;
};

// The pair as a row of one occluded source, to `relative` × its unoccluded factor.
PairValue integrate(const PatchMesh& mesh, const Visibility& vis, const Pair& p, double relative) {
  OccludedRowIntegrator integrator(vis, mesh);
  std::vector<OccludedSource> sources(1);
  sources[0].patch = p.j;
  sources[0].exchanging_part = p.spart;
  sources[0].occluders = p.occluders;
  const double f0 = unoccluded(p);
  std::vector<double> blocked;
  PairValue v;
  v.row = integrator.integrate(p.i, sources, relative * f0, 50000000, blocked);
  v.form_factor = f0 - blocked[0];
  return v;
}

// The visible factor averaged over an n × n midpoint grid of a rectangular receiver (brute force).
double brute_force(const Visibility& vis, const Pair& p, int n) {
  double sum = 0.0;
  RayTally rays;
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) {
      const double u = (a + 0.5) / n, v = (b + 0.5) / n;
      const Vec3 x = p.r[0] + u * (p.r[1] - p.r[0]) + v * (p.r[3] - p.r[0]);
      const Receiver at{x, p.rnormal};
      const double f0 = lambert_form_factor(at, p.s, p.sn);
      sum += vis.point_to_patch(at, p.s, p.sn, p.snormal, f0, p.occluders, 0, 0, rays);
    }
  return sum / (double(n) * n);
}

// The cell rule: exact for every monomial u^a v^b of degree <= 7 (its embedded rule for degree
// <= 5), whose mean over [−1, 1]² is 1/((a+1)(b+1)) for even a and b, else 0; and neither rule
// is exact one degree higher (the difference is the error estimate).
TEST(OccludedPairs, GenzMalikRuleIsExactToDegreeSevenAndFive) {
  const GenzMalikRule rule;
  const auto exact = [](int a, int b) { return a % 2 || b % 2 ? 0.0 : 1.0 / ((a + 1.0) * (b + 1.0)); };
  for (int a = 0; a <= 8; ++a)
    for (int b = 0; a + b <= 8; ++b) {
      double f[GenzMalikRule::kPoints];
      for (int q = 0; q < GenzMalikRule::kPoints; ++q) f[q] = std::pow(rule.u[q], a) * std::pow(rule.v[q], b);
      double mean7, mean5;
      rule.means(f, mean7, mean5);
      SCOPED_TRACE(testing::Message() << "u^" << a << " v^" << b);
      if (a + b <= 7) { EXPECT_NEAR(mean7, exact(a, b), 1e-14); }
      if (a + b <= 5) { EXPECT_NEAR(mean5, exact(a, b), 1e-14); }
    }
  double f[GenzMalikRule::kPoints], mean7, mean5;
  for (int q = 0; q < GenzMalikRule::kPoints; ++q) f[q] = std::pow(rule.u[q], 8);
  rule.means(f, mean7, mean5);
  EXPECT_GT(std::abs(mean7 - 1.0 / 9.0), 1e-6);
  for (int q = 0; q < GenzMalikRule::kPoints; ++q) f[q] = std::pow(rule.u[q], 6);
  rule.means(f, mean7, mean5);
  EXPECT_GT(std::abs(mean5 - 1.0 / 7.0), 1e-6);
}

TEST(OccludedPairs, FloatingBoxShadowAgreesWithBruteForce) {
  // Floor and ceiling of the unit cube with a box floating between them, off-centre: a partial
  // shadow with smooth penumbrae.
  const Scene scene = cube_with_box({0.3, 0.35, 0.4}, {0.6, 0.55, 0.5});
  const PatchMesh mesh = subdivide(scene, {});
  const Visibility vis(scene, VisibilityMethod::Exact);
  const Pair p = pair_of(mesh, vis, 0, 1);
  ASSERT_FALSE(p.occluders.empty());
  const double reference = brute_force(vis, p, 400);
  const PairValue r = integrate(mesh, vis, p, 1e-7);
  EXPECT_FALSE(r.row.budget_exhausted);
  EXPECT_LT(r.form_factor, unoccluded(p) - 0.01);  // the box does cast a shadow
  // The midpoint grid's own error is about 1e-6 of F at n = 400 (kinks along the penumbrae).
  EXPECT_NEAR(r.form_factor, reference, 3e-6 * reference);
  EXPECT_LT(r.row.error, 1e-6 * reference);
}

TEST(OccludedPairs, ThinShadowAtAContactIsFound) {
  // A box standing on the floor, the floor patch beside it, and a wall patch the box partly hides:
  // near the contact line the shadow narrows to nothing, thinner than a fixed rule's spacing.
  const BoxOnFloor room({0.4, 0.4, 0.0}, {0.5, 0.6, 0.3});  // floor patches touch the box's faces
  const PatchMesh& mesh = room.mesh;
  const Visibility vis(room.scene, VisibilityMethod::Exact);
  // Receiver: the floor patch of x in [0.5, 1], y in [0.5, 1]; source: the wall x = 0, upper half.
  const int receiver = room.floor_quarter(true, true);
  int source = -1;
  for (int k = 0; k < mesh.size(); ++k) {
    const Patch& q = mesh.patches[size_t(k)];
    if (q.face == 5 && q.centroid.z() > 0.5 && q.centroid.y() > 0.5) source = k;
  }
  ASSERT_GE(receiver, 0);
  ASSERT_GE(source, 0);
  const Pair p = pair_of(mesh, vis, receiver, source);
  ASSERT_FALSE(p.occluders.empty());
  const double reference = brute_force(vis, p, 600);
  const PairValue r = integrate(mesh, vis, p, 1e-6);
  EXPECT_NEAR(r.form_factor, reference, 2e-5 * reference);
}

TEST(OccludedPairs, RowsOfAClosedRoomSumToOne) {
  // Every face of a closed room with a floating box inside sees a full hemisphere of the room's
  // faces: every row sums to 1. The fixed 6 × 6 rule leaves the rows of patches in partial
  // shadow off by more than the adaptive rule does.
  const Scene scene = cube_with_box({0.3, 0.35, 0.3}, {0.6, 0.55, 0.5});
  PatchingOptions patching;
  patching.max_edge = 0.34;
  const PatchMesh mesh = subdivide(scene, patching);
  const Visibility vis(scene, VisibilityMethod::Exact);
  double worst[2] = {0.0, 0.0};
  long long adaptive_pairs = 0;
  for (int adaptive = 0; adaptive < 2; ++adaptive) {
    FillOptions o;
    o.tolerance = 1e-7;
    o.quadrature = 6;
    o.visibility = &vis;
    o.occluded_tolerance = adaptive ? 1e-6 : 0.0;
    FillStats stats;
    const FormFactors F = fill_form_factors(mesh, o, stats);
    for (int i = 0; i < mesh.size(); ++i) worst[adaptive] = std::max(worst[adaptive], std::abs(F.row_sum(i) - 1.0));
    if (adaptive) {
      adaptive_pairs = stats.pairs_occluded_adaptive;
      EXPECT_EQ(stats.pairs_fixed_rule, 0);
      EXPECT_EQ(stats.occluded_budget_exhausted, 0);
      EXPECT_GT(stats.occluded_evaluations, 17 * stats.pairs_occluded_adaptive / 2);
    }
  }
  EXPECT_GT(adaptive_pairs, 0);
  EXPECT_LT(worst[1], 2e-6);
  EXPECT_LT(worst[1], worst[0]);
}

TEST(OccludedPairs, RowErrorEstimateBoundsTheRowSumsError) {
  // The same room at a coarse tolerance: every row's sum is within its estimated error (and so
  // within the tolerance) of 1.
  const Scene scene = cube_with_box({0.3, 0.35, 0.3}, {0.6, 0.55, 0.5});
  PatchingOptions patching;
  patching.max_edge = 0.34;
  const PatchMesh mesh = subdivide(scene, patching);
  const Visibility vis(scene, VisibilityMethod::Exact);
  FillOptions o;
  o.tolerance = 1e-9;
  o.visibility = &vis;
  o.occluded_tolerance = 1e-3;
  FillStats stats;
  const FormFactors F = fill_form_factors(mesh, o, stats);
  EXPECT_LE(stats.max_row_error_estimate, 1e-3);
  for (int i = 0; i < mesh.size(); ++i) EXPECT_LE(std::abs(F.row_sum(i) - 1.0), stats.max_row_error_estimate + 1e-8);
}

TEST(OccludedPairs, AReceiverUnderASolidSeesNothingFromItsFootprint) {
  // A closed box stands on one floor patch of a closed room: points of its footprint see nothing,
  // the rest of the patch a whole hemisphere, so the patch's row sums to 1 − A_footprint / A.
  const BoxOnFloor room({0.1, 0.1, 0.0}, {0.3, 0.2, 0.25});
  const PatchMesh& mesh = room.mesh;
  const Visibility vis(room.scene, VisibilityMethod::Exact);
  const int receiver = room.floor_quarter(false, false);
  ASSERT_GE(receiver, 0);
  FillOptions o;
  o.tolerance = 1e-9;
  o.visibility = &vis;
  o.occluded_tolerance = 1e-7;
  FillStats stats;
  const FormFactors F = fill_form_factors(mesh, o, stats);
  const double footprint = 0.2 * 0.1, area = mesh.patches[size_t(receiver)].area;
  EXPECT_NEAR(F.row_sum(receiver), 1.0 - footprint / area, 1e-6);
  EXPECT_GT(stats.pairs_occluded_adaptive, 0);
}

TEST(OccludedPairs, AReceiverWhollyUnderASolidIsSettledWithoutAPoint) {
  // A box stands exactly on one floor patch: the patch sees nothing, so every source's blocked
  // part is its whole unoccluded factor, found from the footprint without evaluating a point.
  const BoxOnFloor room({0.0, 0.0, 0.0}, {0.5, 0.5, 0.25});
  const PatchMesh& mesh = room.mesh;
  const Visibility vis(room.scene, VisibilityMethod::Exact);
  const int receiver = room.floor_quarter(false, false);
  ASSERT_GE(receiver, 0);
  std::vector<OccludedSource> sources;
  std::vector<Pair> pairs;
  for (int j = 0; j < mesh.size(); ++j) {
    if (mesh.patches[size_t(j)].face == 0 || mesh.patches[size_t(j)].face >= 6) continue;  // the room's walls
    const Pair p = pair_of(mesh, vis, receiver, j);
    if (p.occluders.empty() || p.spart.size() < 3) continue;
    sources.push_back({j, p.spart, p.occluders});
    pairs.push_back(p);
  }
  ASSERT_GE(sources.size(), 4u);
  OccludedRowIntegrator integrator(vis, mesh);
  std::vector<double> blocked;
  const OccludedRowResult r = integrator.integrate(receiver, sources, 1e-9, 50000000, blocked);
  EXPECT_EQ(r.points, 0);
  for (size_t k = 0; k < sources.size(); ++k) EXPECT_NEAR(blocked[k], unoccluded(pairs[k]), 1e-9);
}

TEST(OccludedPairs, SourcesOfARowGiveWhatEachGivesAlone) {
  // Sharing receiver points between the sources of a row changes no entry beyond the tolerance:
  // the row against each source alone, integrated far below it.
  const Scene scene = cube_with_box({0.3, 0.35, 0.4}, {0.6, 0.55, 0.5});
  PatchingOptions patching;
  patching.max_edge = 0.5;
  const PatchMesh mesh = subdivide(scene, patching);
  const Visibility vis(scene, VisibilityMethod::Exact);
  int receiver = -1;
  for (int k = 0; k < mesh.size() && receiver < 0; ++k)
    if (mesh.patches[size_t(k)].face == 0) receiver = k;
  std::vector<OccludedSource> sources;
  for (int j = 0; j < mesh.size(); ++j) {
    if (mesh.patches[size_t(j)].face != 1) continue;  // the ceiling, across the box
    const Pair p = pair_of(mesh, vis, receiver, j);
    if (!p.occluders.empty()) sources.push_back({j, p.spart, p.occluders});
  }
  ASSERT_GE(sources.size(), 2u);
  OccludedRowIntegrator integrator(vis, mesh);
  std::vector<double> together;
  const double tolerance = 1e-8;
  const OccludedRowResult r = integrator.integrate(receiver, sources, tolerance, 50000000, together);
  EXPECT_LE(r.error, tolerance);
  EXPECT_FALSE(r.budget_exhausted);
  double sum_error = 0.0;
  for (size_t k = 0; k < sources.size(); ++k) {
    std::vector<double> alone;
    integrator.integrate(receiver, {sources[k]}, 1e-11, 50000000, alone);
    EXPECT_GT(alone[0], 1e-3);  // each is shadowed
    sum_error += together[k] - alone[0];
  }
  EXPECT_LE(std::abs(sum_error), tolerance);
}

}  // namespace
