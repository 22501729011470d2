// View factors on the unit cube against exact rectangle formulas; aggregation; enforcement.
//
// Reference values: every patch of an n × n meshed cube wall is an axis-aligned rectangle, so
// every patch-to-patch factor has a closed form by superposition of Howell's catalog cases C-11
// (parallel rectangles) and C-14 (perpendicular rectangles with a common edge) — J. R. Howell,
// "A Catalog of Radiation Heat Transfer Configuration Factors", 3rd ed. The superposed sums are
// written out as in Ehlert & Smith, "View factors for perpendicular and parallel rectangular
// plates", J. Thermophysics Heat Transfer 7(1), 1993, eqs. 3–6, evaluated in long double:
//   parallel, distance z:   A1 F12 = (1/2π) Σ_{ijkl} (−1)^{i+j+k+l} Gp(x_i − ξ_k, y_j − η_l, z)
//     Gp(x, y, z) = x √(y²+z²) atan(x/√(y²+z²)) + y √(x²+z²) atan(y/√(x²+z²)) − (z²/2) ln(x²+y²+z²)
//   perpendicular, common axis x, y and η distances from the common line:
//                           A1 F12 = (1/2π) Σ_{ijkl} (−1)^{i+j+k+l} Gq(x_i − ξ_k, y_j, η_l)
//     Gq(x, y, η) = x √(y²+η²) atan(x/√(y²+η²)) − ¼ (y² + η² − x²) ln(x² + y² + η²)
// Both reduce to C-11 / C-14 for single rectangles (checked first: 0.19982489569838738 and
// 0.20004377607540315, refs cube_floor_to_ceiling / cube_floor_to_wall).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "rectangle_reference.h"
#include "scene_builders.h"
#include "viewfactors/viewfactors.h"

using namespace photometria;

namespace {

using rect_ref::ld;

// F from rectangle [x0,x1]×[y0,y1] to [s0,s1]×[e0,e1] in parallel planes a distance z apart.
ld parallel(ld x0, ld x1, ld y0, ld y1, ld s0, ld s1, ld e0, ld e1, ld z) {
  return rect_ref::parallel_af(x0, x1, y0, y1, s0, s1, e0, e1, z) / ((x1 - x0) * (y1 - y0));
}

// F from [x0,x1] × [y0,y1] (y = distance from the common line) to [s0,s1] × [e0,e1] (e = distance).
ld perpendicular(ld x0, ld x1, ld y0, ld y1, ld s0, ld s1, ld e0, ld e1) {
  return rect_ref::perpendicular_af(x0, x1, y0, y1, s0, s1, e0, e1) / ((x1 - x0) * (y1 - y0));
}

struct Box {
  int axis;  // normal axis
  ld plane;  // coordinate along it
  ld lo[3], hi[3];
};

Box box_of(const PatchMesh& mesh, int p) {
  Box b{};
  const Patch& pa = mesh.patches[p];
  for (int k = 0; k < 3; ++k) {
    b.lo[k] = 1e30L;
    b.hi[k] = -1e30L;
  }
  for (int c = 0; c < pa.corner_count; ++c)
    for (int k = 0; k < 3; ++k) {
      b.lo[k] = std::min<ld>(b.lo[k], mesh.points[pa.corners[c]][k]);
      b.hi[k] = std::max<ld>(b.hi[k], mesh.points[pa.corners[c]][k]);
    }
  for (int k = 0; k < 3; ++k)
    if (std::abs(pa.normal[k]) > 0.5) b.axis = k;
  b.plane = b.lo[b.axis];
  return b;
}

// Exact F between two patches of the axis-aligned unit cube (inward normals).
ld exact(const Box& p, const Box& q) {
  if (p.axis == q.axis) {
    if (p.plane == q.plane) return 0;
    const int u = (p.axis + 1) % 3, v = (p.axis + 2) % 3;
    return parallel(p.lo[u], p.hi[u], p.lo[v], p.hi[v], q.lo[u], q.hi[u], q.lo[v], q.hi[v],
                    std::abs(p.plane - q.plane));
  }
  const int a = p.axis, b = q.axis, c = 3 - a - b;  // c: the common axis
  // Distances from the common line {x_a = p.plane, x_b = q.plane}: p spans x_b, q spans x_a.
  const ld y0 = std::min(std::abs(p.lo[b] - q.plane), std::abs(p.hi[b] - q.plane));
  const ld y1 = std::max(std::abs(p.lo[b] - q.plane), std::abs(p.hi[b] - q.plane));
  const ld e0 = std::min(std::abs(q.lo[a] - p.plane), std::abs(q.hi[a] - p.plane));
  const ld e1 = std::max(std::abs(q.lo[a] - p.plane), std::abs(q.hi[a] - p.plane));
  return perpendicular(p.lo[c], p.hi[c], y0, y1, q.lo[c], q.hi[c], e0, e1);
}

PatchViewFactors cube_factors(int n) {
  ViewFactorOptions o;  // command defaults
  o.patching.max_edge = (1.0 + 1e-9) / n;
  return compute_view_factors(builders::unit_cube(), o);
}

}  // namespace

TEST(ViewFactorsReference, ClosedFormsReduceToHowellC11AndC14) {
  EXPECT_NEAR(double(parallel(0, 1, 0, 1, 0, 1, 0, 1, 1)), 0.19982489569838738, 1e-15);
  EXPECT_NEAR(double(perpendicular(0, 1, 0, 1, 0, 1, 0, 1)), 0.20004377607540315, 1e-15);
}

class CubeMesh : public ::testing::TestWithParam<int> {};

namespace {
void check_cube(int n) {
  const PatchViewFactors r = cube_factors(n);
  ASSERT_EQ(r.mesh.size(), 6 * n * n);
  EXPECT_EQ(r.visibility_mode, "none");
  std::vector<Box> boxes;
  for (int i = 0; i < r.mesh.size(); ++i) boxes.push_back(box_of(r.mesh, i));
  double worst_rel = 0.0, worst_abs_small = 0.0, worst_row = 0.0;
  for (int i = 0; i < r.mesh.size(); ++i) {
    for (int j = 0; j < r.mesh.size(); ++j) {
      const double want = double(exact(boxes[i], boxes[j]));
      const double got = r.F(i, j);
      if (want > 1e-3) worst_rel = std::max(worst_rel, std::abs(got - want) / want);
      else worst_abs_small = std::max(worst_abs_small, std::abs(got - want));
    }
    worst_row = std::max(worst_row, std::abs(r.F.row_sum(i) - 1.0));
  }
  // The accuracy target is 1e-6 relative and row sums within 1e-6; every pair here is a pair of
  // aligned rectangles, computed in closed form (formfactors/aligned_rectangles.h), so far tighter.
  EXPECT_LE(worst_rel, 1e-12) << "n = " << n;
  EXPECT_LE(worst_abs_small, 1e-15) << "n = " << n;
  EXPECT_LE(worst_row, 1e-12) << "n = " << n;
  std::printf("cube n = %d: max rel error (F > 1e-3) %.3g, max abs error (F <= 1e-3) %.3g, max |row sum - 1| %.3g\n", n,
              worst_rel, worst_abs_small, worst_row);
}
}  // namespace

TEST_P(CubeMesh, EveryPatchFactorMatchesTheExactFormulas) { check_cube(GetParam()); }

// Larger meshes for the figures in docs/viewfactors.md, outside CI:
// PHOTOMETRIA_VF_CUBE_N=16 ./test_viewfactors --gtest_filter='*LargerMesh*'
TEST(ViewFactors, LargerMeshFromEnvironment) {
  const char* n = std::getenv("PHOTOMETRIA_VF_CUBE_N");
  if (!n) GTEST_SKIP() << "set PHOTOMETRIA_VF_CUBE_N to run";
  check_cube(std::atoi(n));
}

INSTANTIATE_TEST_SUITE_P(ViewFactors, CubeMesh, ::testing::Values(4, 8));

TEST(ViewFactors, GroupAggregationGivesTheWallMatrix) {
  Scene s = builders::unit_cube();
  s.groups = {"floor", "ceiling", "south", "east", "north", "west"};
  for (size_t f = 0; f < s.faces.size(); ++f) s.faces[f].group = int(f);
  ViewFactorOptions o;
  o.patching.max_edge = (1.0 + 1e-9) / 4;
  const PatchViewFactors r = compute_view_factors(s, o);
  const Aggregation agg = make_aggregation(s, r.mesh, AggregateLevel::Group);
  ASSERT_EQ(agg.size(), 6);
  EXPECT_EQ(agg.names[1], "ceiling");
  const ViewFactorMatrix G = aggregate(r.F, r.mesh, agg);
  const int opposite[6] = {1, 0, 4, 5, 2, 3};
  for (int i = 0; i < 6; ++i) {
    EXPECT_NEAR(agg.areas[i], 1.0, 1e-14);
    for (int j = 0; j < 6; ++j) {
      const double want = i == j ? 0.0 : j == opposite[i] ? 0.19982489569838738 : 0.20004377607540315;
      EXPECT_NEAR(G(i, j), want, 1e-6 * want + 1e-15) << i << "," << j;
    }
  }
  // Face level on this scene is the same partition.
  const Aggregation faces = make_aggregation(s, r.mesh, AggregateLevel::Face);
  EXPECT_LE((aggregate(r.F, r.mesh, faces) - G).cwiseAbs().maxCoeff(), 1e-15);
}

// The consuming aggregate: one patch per output surface hands the patch matrix over (no copy,
// the source left 0 × 0); anything else falls back to the weighted sum, with the same values.
TEST(ViewFactors, ConsumingAggregationHandsOverOnlyTheIdentityPartition) {
  const PatchViewFactors r = cube_factors(2);
  const Aggregation patches = make_aggregation(builders::unit_cube(), r.mesh, AggregateLevel::Patch);
  FormFactors moved = r.F;
  const double* entries = moved.dense_double_row(0);
  ASSERT_NE(entries, nullptr);
  const ViewFactorMatrix P = aggregate(std::move(moved), r.mesh, patches);
  EXPECT_EQ(P.data(), entries);  // the same memory, not a copy
  EXPECT_EQ(moved.rows(), 0);    // NOLINT(bugprone-use-after-move): left empty on purpose
  EXPECT_EQ(P, aggregate(r.F, r.mesh, patches));

  const Aggregation faces = make_aggregation(builders::unit_cube(), r.mesh, AggregateLevel::Face);
  FormFactors kept = r.F;
  const ViewFactorMatrix G = aggregate(std::move(kept), r.mesh, faces);
  EXPECT_EQ(G.rows(), 6);
  EXPECT_EQ(kept.rows(), r.F.rows());  // NOLINT(bugprone-use-after-move): the fallback only reads
  EXPECT_EQ(G, aggregate(r.F, r.mesh, faces));

  FormFactors sparse(4, MatrixLayout::Sparse, MatrixPrecision::Double);
  EXPECT_THROW(sparse.release_dense_double(), std::logic_error);
}

TEST(ViewFactors, EnforcementBothGivesSymmetricAFAndUnitRows) {
  const PatchViewFactors r = cube_factors(4);
  const Aggregation agg = make_aggregation(builders::unit_cube(), r.mesh, AggregateLevel::Patch);
  ViewFactorMatrix F = r.F.to_dense();
  // Perturb so that there is something to fix: 1e-3 relative noise, deterministic.
  for (int i = 0; i < F.rows(); ++i)
    for (int j = 0; j < F.cols(); ++j) F(i, j) *= 1.0 + 1e-3 * std::sin(1.0 + 7.0 * i + 3.0 * j);
  const EnforcementReport rep = enforce(F, agg.areas, Enforcement::Both);
  EXPECT_GT(rep.before.reciprocity_error, 1e-6);
  EXPECT_GT(rep.before.max_row_sum - rep.before.min_row_sum, 1e-6);
  EXPECT_LE(rep.after.reciprocity_error, 1e-15);
  EXPECT_NEAR(rep.after.min_row_sum, 1.0, 1e-13);
  EXPECT_NEAR(rep.after.max_row_sum, 1.0, 1e-13);
  EXPECT_LE(rep.max_change, 3e-3 * F.maxCoeff());
  EXPECT_GE(rep.after.min_entry, 0.0);
}

TEST(ViewFactors, ReciprocityAndClosureModes) {
  const std::vector<double> areas = {1.0, 2.0};
  ViewFactorMatrix F(2, 2);
  F << 0.0, 0.9, 0.5, 0.4;  // A1 F12 = 0.9, A2 F21 = 1.0
  ViewFactorMatrix R = F;
  enforce(R, areas, Enforcement::Reciprocity);
  EXPECT_NEAR(areas[0] * R(0, 1), 0.95, 1e-15);
  EXPECT_NEAR(areas[1] * R(1, 0), 0.95, 1e-15);
  ViewFactorMatrix C = F;
  const EnforcementReport rep = enforce(C, areas, Enforcement::Closure);
  EXPECT_NEAR(C.row(0).sum(), 1.0, 1e-15);
  EXPECT_NEAR(C.row(1).sum(), 1.0, 1e-15);
  EXPECT_NEAR(rep.before.min_row_sum, 0.9, 1e-15);
  EXPECT_EQ(rep.before.worst_row, 0);
}

TEST(ViewFactors, PointFactorsAtTheCubeCentreOfTheFloor) {
  Scene s = builders::unit_cube();
  s.groups = {"floor", "ceiling", "south", "east", "north", "west"};
  for (size_t f = 0; f < s.faces.size(); ++f) s.faces[f].group = int(f);
  const PatchViewFactors r = compute_view_factors(s, ViewFactorOptions{});
  const Aggregation agg = make_aggregation(s, r.mesh, AggregateLevel::Group);
  SurfacePoint p;
  p.position = Vec3(0.5, 0.5, 0.0);
  p.normal = Vec3::UnitZ();
  const ViewFactorMatrix P = point_view_factors({p}, r.mesh, agg, r.visibility.get(), ViewFactorOptions{});
  // Differential area to a parallel coaxial square of side 1 at distance 1 (Howell B-5 with
  // a = b = 0.5, c = 1, by four quadrants): F = (2/π) [ X/√(1+X²) atan(Y/√(1+X²)) + (X↔Y) ],
  // X = Y = 0.5 per quadrant.
  const double X = 0.5, s1 = std::sqrt(1 + X * X);
  const double ceiling = 4.0 * (1.0 / (2 * M_PI)) * (2.0 * X / s1 * std::atan(X / s1));
  EXPECT_NEAR(P(0, 1), ceiling, 1e-13);
  EXPECT_NEAR(P.row(0).sum(), 1.0, 1e-13);
  EXPECT_EQ(P(0, 0), 0.0);
}
