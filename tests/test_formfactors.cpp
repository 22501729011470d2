#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>
#include <vector>

#include "formfactors/formfactors.h"
#include "formfactors/quadrature.h"
#include "refs.h"
#include "scene_builders.h"
#include "solver/gauss_seidel.h"

using namespace photometria;

TEST(Quadrature, GaussLegendreIntegratesPolynomialsExactly) {
  std::vector<double> x, w;
  gauss_legendre_unit(5, x, w);
  double s0 = 0, s9 = 0;
  for (int i = 0; i < 5; ++i) {
    s0 += w[i];
    s9 += w[i] * std::pow(x[i], 9);
  }
  EXPECT_NEAR(s0, 1.0, 1e-15);
  EXPECT_NEAR(s9, 0.1, 1e-15);  // degree 2n − 1 = 9 is exact
}

TEST(Quadrature, TriangleAndQuadRulesIntegrateAQuadratic) {
  const Vec3 tri[3] = {{0, 0, 0}, {2, 0, 0}, {0, 1, 0}};
  const Vec3 quad[4] = {{0, 0, 0}, {2, 0, 0}, {1.5, 1, 0}, {0, 1, 0}};  // trapezoid: non-constant Jacobian
  for (int order : {2, 3, 4}) {
    double mean_tri = 0, mean_quad = 0;
    for (const auto& q : patch_quadrature(tri, 3, order)) mean_tri += q.weight * q.point.x() * q.point.x();
    for (const auto& q : patch_quadrature(quad, 4, order)) mean_quad += q.weight * q.point.x() * q.point.y();
    EXPECT_NEAR(mean_tri, 2.0 / 3.0, 1e-14);  // (1/A)∫x² dA over the triangle
    EXPECT_NEAR(mean_quad, 0.5 * (2.0 - 2.0 / 3.0 + 1.0 / 16.0) / 1.75, 1e-14) << order;  // ∫xy dA / A
  }
  const auto c = patch_quadrature(tri, 3, 1);
  ASSERT_EQ(c.size(), 1u);
  EXPECT_TRUE(c[0].point.isApprox(Vec3(2.0 / 3, 1.0 / 3, 0)));
}

// One patch per wall of the unit cube: the centroid rule is off; Gauss rules converge to the
// exact patch-to-patch factors (Howell C-11 opposite, C-14 adjacent) and so to the exact 6 × 6
// radiosity solution of refs cube_floor_emitting_rho0.5.
TEST(FormFactors, CubeOnePatchPerWallConvergesWithQuadrature) {
  const Scene cube = builders::cube_floor_emitting(0.5);
  const PatchMesh mesh = subdivide(cube, {});
  ASSERT_EQ(mesh.size(), 6);
  const auto& ref = refs::find("cube_floor_emitting_rho0.5");
  const double f_opp = double(refs::number(refs::find("C11_unit_squares_c1")["value"]));
  const double f_adj = double(refs::number(refs::find("C14_unit")["value"]));
  double previous_error = 1e9;
  for (int order : {1, 2, 4, 8, 16}) {
    FillStats stats;
    FillOptions opt;
    opt.quadrature = order;
    const FormFactorMatrix F = fill_form_factors(mesh, opt, stats).to_dense();
    EXPECT_EQ(stats.pairs_backfacing, 0);
    ChannelMatrix E = ChannelMatrix::Zero(6, 3), rho = ChannelMatrix::Constant(6, 3, 0.5), B;
    E.row(0).setOnes();
    solve_radiosity(F, E, rho, ChannelMatrix::Zero(6, 3), true, {1e-14, 1000}, B);
    double error = 0;
    for (int i = 0; i < 6; ++i)
      error =
          std::max(error, double(std::abs((B(i, 0) - refs::number(ref["value"][i])) / refs::number(ref["value"][i]))));
    EXPECT_LT(error, previous_error) << "order " << order;
    previous_error = error;
    if (order == 16) {
      EXPECT_NEAR(F(0, 1), f_opp, 1e-9);
      EXPECT_NEAR(F(0, 2), f_adj, 2e-4);  // adjacent: the shared edge's singularity slows Gauss down
      EXPECT_LT(error, 2e-4);
    }
  }
}

TEST(FormFactors, ClosedRoomRowsSumToOneForAnyQuadrature) {
  const PatchMesh mesh = subdivide(builders::unit_cube(), {0.25, 0.0});
  for (int order : {1, 3}) {
    FillStats stats;
    FillOptions opt;
    opt.quadrature = order;
    const FormFactorMatrix F = fill_form_factors(mesh, opt, stats).to_dense();
    EXPECT_GT(stats.pairs_backfacing, 0);  // coplanar patches of one wall
    for (int i = 0; i < mesh.size(); ++i) EXPECT_NEAR(F.row(i).sum(), 1.0, 1e-12);
  }
}

// Room with a table: reciprocity to the quadrature error, 0 <= F <= 1, rows <= 1 to rounding
// (visibility per receiver point: the visible fragments of one point tile its hemisphere; see
// formfactors.h). Exact visibility, so only the quadrature breaks reciprocity.
// 8 × 8 Gauss points: the worst pair (a table side and a wall patch cut by the side's plane)
// has a kink in its integrand, so 4 × 4 is 12% off while 8 × 8 is 1.3% off unoccluded; the
// shadow outlines add kinks of their own (2.3% at 8 × 8 with exact visibility).
TEST(FormFactors, RoomWithTableIsReciprocalAndBounded) {
  Scene room = builders::unit_cube(0.5, 1.0);
  builders::add_box(room, Vec3(0.3, 0.3, 0.4), Vec3(0.7, 0.7, 0.45));
  const PatchMesh mesh = subdivide(room, {0.25, 0.0});
  for (VisibilityMethod method : {VisibilityMethod::Exact, VisibilityMethod::Rays}) {
    const Visibility vis(room, method);
    FillOptions opt;
    opt.quadrature = method == VisibilityMethod::Exact ? 8 : 2;
    opt.visibility = &vis;
    opt.rays = 64;
    FillStats stats;
    const FormFactorMatrix F = fill_form_factors(mesh, opt, stats).to_dense();
    EXPECT_EQ(stats.rays_cast > 0, method == VisibilityMethod::Rays);
    EXPECT_GT(stats.pairs_occluded, 0);
    double worst = 0;
    for (int i = 0; i < mesh.size(); ++i) {
      EXPECT_LE(F.row(i).sum(), 1.0 + 1e-12);
      for (int j = 0; j < mesh.size(); ++j) {
        EXPECT_GE(F(i, j), 0.0);
        EXPECT_LE(F(i, j), 1.0);
        const double ai = mesh.patches[i].area * F(i, j), aj = mesh.patches[j].area * F(j, i);
        if (std::max(ai, aj) > 1e-3 * mesh.patches[i].area)
          worst = std::max(worst, std::abs(ai - aj) / std::max(ai, aj));
      }
    }
    if (method == VisibilityMethod::Exact) { EXPECT_LT(worst, 0.03); }
  }
}

// Streamed rows of a convex scene of rectangles, mirrored in bands (FillOptions::
// streamed_mirror_bytes): every row reaches the sink once, in order, with the same bits as the
// stored fill, which mirrors its closed forms after the loop; each closed form is computed once.
// 600 patches: three bands, the last one partial.
TEST(FormFactors, StreamedMirroredRowsEqualTheStoredRows) {
  const PatchMesh mesh = subdivide(builders::unit_cube(), {0.1 + 1e-9, 0.0});
  const int n = mesh.size();
  ASSERT_EQ(n, 600);
  FillOptions opt;
  opt.tolerance = 1e-7;  // the per-pair rule: closed forms for aligned rectangles
  FillStats stored_stats;
  const FormFactors stored = fill_form_factors(mesh, opt, stored_stats);
  ASSERT_TRUE(stored_stats.mirrored);
  ASSERT_EQ(stored.layout(), MatrixLayout::Dense);

  for (const bool mirrored : {true, false}) {
    SCOPED_TRACE(mirrored ? "mirrored" : "every entry in its row");
    std::vector<std::vector<double>> rows(static_cast<size_t>(n));
    std::vector<int> order;
    std::mutex m;
    FillOptions streamed = opt;
    streamed.streamed_mirror_bytes = mirrored ? streamed_mirror_peak_bytes(n) : streamed_mirror_peak_bytes(n) - 1;
    streamed.row_sink = [&](int i, const double* row) {
      std::lock_guard<std::mutex> lock(m);
      rows[size_t(i)].assign(row, row + n);
      order.push_back(i);
      return true;
    };
    FillStats stats;
    const FormFactors none = fill_form_factors(mesh, streamed, stats);
    EXPECT_EQ(none.rows(), 0);
    EXPECT_EQ(stats.mirrored, mirrored);
    EXPECT_EQ(stats.pairs_exact_rectangles, stored_stats.pairs_exact_rectangles);
    EXPECT_EQ(stats.pairs_backfacing, stored_stats.pairs_backfacing);
    ASSERT_EQ(int(order.size()), n);
    if (mirrored) {  // band after band (of 256 rows; in any order within a band)
      for (size_t k = 1; k < order.size(); ++k) EXPECT_LE(order[k - 1] / 256, order[k] / 256);
    }
    long long differ = 0;
    double worst = 0.0;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        const double a = stored(i, j), b = rows[size_t(i)][size_t(j)];
        differ += a != b;
        worst = std::max(worst, std::abs(a - b) / std::max(a, 1e-300));
      }
    // Computed in its own row, an entry below the diagonal may differ from the mirrored one in
    // its last bits (area_factor / A_i against (area_factor / A_j) A_j / A_i).
    if (mirrored) {
      EXPECT_EQ(differ, 0);
    } else {
      EXPECT_LT(worst, 1e-15);
    }
  }
}

// A sink that refuses a row stops the banded fill after that row's band.
TEST(FormFactors, StreamedMirroredFillStopsWhenTheSinkRefuses) {
  const PatchMesh mesh = subdivide(builders::unit_cube(), {0.1 + 1e-9, 0.0});
  const int n = mesh.size();
  FillOptions opt;
  opt.tolerance = 1e-7;
  opt.streamed_mirror_bytes = streamed_mirror_peak_bytes(n);
  std::atomic<int> received{0};
  opt.row_sink = [&](int i, const double*) {
    ++received;
    return i != 10;
  };
  FillStats stats;
  fill_form_factors(mesh, opt, stats);
  EXPECT_GE(received.load(), 11);
  EXPECT_LE(received.load(), 256);  // the first band only
}
