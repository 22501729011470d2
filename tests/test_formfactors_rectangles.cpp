// Exact form factors between axis-aligned rectangles (formfactors/aligned_rectangles.h).
//
// References, all independent of the class under test:
//  - the superposed closed forms of Howell's catalog C-11 / C-14 as written out by Ehlert &
//    Smith, J. Thermophysics Heat Transfer 7(1), 1993, eqs. 3–6, evaluated term by term in long
//    double from the world coordinates (the same formulas as tests/test_viewfactors.cpp), with
//    the one-sided clipping done here by hand;
//  - the single-rectangle values 0.19982489569838738 (opposite walls of the unit cube) and
//    0.20004377607540315 (adjacent walls), refs cube_floor_to_ceiling / cube_floor_to_wall;
//  - for far pairs, 8 × 8 × 8 × 8 Gauss–Legendre of the point-to-point kernel
//    cos θ1 cos θ2 / (π r²) in long double (no cancellation: it measures the true error of the
//    16-term sum);
//  - for a straddling perpendicular pair, graded composite Gauss quadrature of Lambert's
//    point-to-polygon kernel (kernels/lambert.h, which clips the source at the receiver's
//    horizon).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "formfactors/aligned_rectangles.h"
#include "formfactors/quadrature.h"
#include "kernels/lambert.h"
#include "patching/patching.h"
#include "rectangle_reference.h"
#include "scene_builders.h"

using namespace photometria;

namespace {

using rect_ref::kPi;
using rect_ref::ld;
using rect_ref::parallel_af;
using rect_ref::perpendicular_af;

// A world-aligned rectangle patch: normal sign × e_axis, plane coordinate, extents.
struct Box {
  int axis = 0, sign = 1;
  ld plane = 0, lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
};

Box box_of(const PatchMesh& mesh, int p) {
  Box b;
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
    if (std::abs(pa.normal[k]) > 0.5) {
      b.axis = k;
      b.sign = pa.normal[k] > 0 ? 1 : -1;
    }
  b.plane = b.lo[b.axis];
  return b;
}

// Reference A_p F_pq, one-sided, with each rectangle clipped to the other's front half-space.
ld reference(const Box& p, const Box& q) {
  if (p.axis == q.axis) {
    if (p.sign == q.sign) return 0;
    const ld z = p.sign * (q.plane - p.plane);
    if (z <= 0) return 0;
    const int u = (p.axis + 1) % 3, v = (p.axis + 2) % 3;
    return parallel_af(p.lo[u], p.hi[u], p.lo[v], p.hi[v], q.lo[u], q.hi[u], q.lo[v], q.hi[v], z);
  }
  const int a = p.axis, b = q.axis, c = 3 - a - b;
  // Distances from the common line {x_a = p.plane, x_b = q.plane}, in front of the other plane.
  ld y0 = q.sign * (p.lo[b] - q.plane), y1 = q.sign * (p.hi[b] - q.plane);
  ld e0 = p.sign * (q.lo[a] - p.plane), e1 = p.sign * (q.hi[a] - p.plane);
  if (y0 > y1) std::swap(y0, y1);
  if (e0 > e1) std::swap(e0, e1);
  if (y1 <= 0 || e1 <= 0) return 0;
  return perpendicular_af(p.lo[c], p.hi[c], std::max<ld>(0, y0), y1, q.lo[c], q.hi[c], std::max<ld>(0, e0), e1);
}

// Far pairs: Gauss–Legendre m^4 of cos θ1 cos θ2 / (π r²) over both rectangles, long double.
ld gauss_far(const PatchMesh& mesh, int i, int j, int m) {
  std::vector<double> t, w;
  gauss_legendre_unit(m, t, w);
  const Patch& a = mesh.patches[i];
  const Patch& b = mesh.patches[j];
  const Vec3 a0 = mesh.points[a.corners[0]], au = mesh.points[a.corners[1]] - a0, av = mesh.points[a.corners[3]] - a0;
  const Vec3 b0 = mesh.points[b.corners[0]], bu = mesh.points[b.corners[1]] - b0, bv = mesh.points[b.corners[3]] - b0;
  ld sum = 0;
  for (int i1 = 0; i1 < m; ++i1)
    for (int j1 = 0; j1 < m; ++j1) {
      ld x[3];
      for (int k = 0; k < 3; ++k) x[k] = ld(a0[k]) + ld(t[i1]) * au[k] + ld(t[j1]) * av[k];
      for (int i2 = 0; i2 < m; ++i2)
        for (int j2 = 0; j2 < m; ++j2) {
          ld r[3], r2 = 0, c1 = 0, c2 = 0;
          for (int k = 0; k < 3; ++k) {
            r[k] = ld(b0[k]) + ld(t[i2]) * bu[k] + ld(t[j2]) * bv[k] - x[k];
            r2 += r[k] * r[k];
            c1 += a.normal[k] * r[k];
            c2 -= b.normal[k] * r[k];
          }
          sum += ld(w[i1]) * w[j1] * w[i2] * w[j2] * c1 * c2 / (r2 * r2);
        }
    }
  return sum * a.area * b.area / kPi;
}

PatchMesh cube_mesh(int n, const Eigen::Matrix3d& R = Eigen::Matrix3d::Identity(), const Vec3& shift = Vec3::Zero()) {
  Scene s = builders::unit_cube();
  for (Vec3& v : s.vertices) v = R * v + shift;
  return subdivide(s, {(1.0 + 1e-9) / n, 0.0});
}

// Appends the world-aligned rectangle [u0,u1]×[v0,v1] (slot axes (axis+1)%3, (axis+2)%3) in
// the plane x_axis = offset, front towards sign × e_axis, corners from the exact coordinates.
void add_rect(PatchMesh& m, int axis, int sign, double offset, double u0, double u1, double v0, double v1) {
  auto point = [&](double u, double v) {
    Vec3 p;
    p[axis] = offset;
    p[(axis + 1) % 3] = u;
    p[(axis + 2) % 3] = v;
    return p;
  };
  const int b = static_cast<int>(m.points.size());
  m.points.push_back(point(u0, v0));
  if (sign > 0) {
    m.points.push_back(point(u1, v0));
    m.points.push_back(point(u1, v1));
    m.points.push_back(point(u0, v1));
  } else {
    m.points.push_back(point(u0, v1));
    m.points.push_back(point(u1, v1));
    m.points.push_back(point(u1, v0));
  }
  Patch p;
  p.corners = {b, b + 1, b + 2, b + 3};
  p.corner_count = 4;
  p.normal = Vec3::Zero();
  p.normal[axis] = sign;
  p.area = (u1 - u0) * (v1 - v0);
  p.centroid = point((u0 + u1) / 2, (v0 + v1) / 2);
  m.patches.push_back(p);
}

void add_polygon(PatchMesh& m, const std::vector<Vec3>& corners) {
  Patch p;
  p.corner_count = static_cast<int>(corners.size());
  for (int k = 0; k < p.corner_count; ++k) {
    p.corners[k] = static_cast<int>(m.points.size());
    m.points.push_back(corners[k]);
  }
  p.normal = polygon_normal(corners);
  p.area = polygon_area(corners);
  p.centroid = polygon_centroid(corners);
  m.patches.push_back(p);
}

struct Comparison {
  double max_rel = 0.0;  // over pairs with F > 1e-6 (either direction)
  double max_abs_small = 0.0;
  double max_row = 0.0;    // max |Σ_j F_ij − 1|
  bool reciprocal = true;  // area_factor(i, j) == area_factor(j, i) bit for bit
  bool all_eligible = true;
};

// Every pair of `mesh` against the long-double reference (world-aligned meshes).
Comparison compare_all(const PatchMesh& mesh, const AlignedRectangles& ar) {
  const int n = mesh.size();
  std::vector<Box> boxes;
  for (int i = 0; i < n; ++i) boxes.push_back(box_of(mesh, i));
  Comparison c;
  for (int i = 0; i < n; ++i) {
    ld row = 0;
    for (int j = 0; j < n; ++j) {
      c.all_eligible = c.all_eligible && ar.eligible(i, j);
      const double got = ar.area_factor(i, j);
      const ld want = i == j ? 0 : reference(boxes[i], boxes[j]);
      if (got != ar.area_factor(j, i)) c.reciprocal = false;
      const double fi = double(want) / mesh.patches[i].area, fj = double(want) / mesh.patches[j].area;
      if (std::max(fi, fj) > 1e-6) c.max_rel = std::max(c.max_rel, double(std::abs(got - want) / want));
      else
        c.max_abs_small = std::max(c.max_abs_small,
                                   std::abs(got - double(want)) / std::min(mesh.patches[i].area, mesh.patches[j].area));
      row += got;
    }
    c.max_row = std::max(c.max_row, double(std::abs(row / mesh.patches[i].area - 1)));
  }
  return c;
}

}  // namespace

TEST(AlignedRectangles, SingleRectangleCubeGivesHowellC11AndC14) {
  const PatchMesh mesh = cube_mesh(1);
  ASSERT_EQ(mesh.size(), 6);
  const AlignedRectangles ar(mesh);
  EXPECT_EQ(ar.summary().rectangles, 6);
  EXPECT_EQ(ar.summary().frames, 1);
  EXPECT_EQ(ar.summary().planes, 6);
  EXPECT_EQ(ar.summary().plane_pairs_exchanging, 15);
  // Face order: floor z=0, ceiling z=1, wall y=0, wall x=1, wall y=1, wall x=0.
  const int opposite[6] = {1, 0, 4, 5, 2, 3};
  for (int i = 0; i < 6; ++i) {
    double row = 0.0;
    for (int j = 0; j < 6; ++j) {
      ASSERT_TRUE(ar.eligible(i, j));
      const double want = i == j ? 0.0 : j == opposite[i] ? 0.19982489569838738 : 0.20004377607540315;
      EXPECT_NEAR(ar.area_factor(i, j), want, 1e-14) << i << "," << j;
      row += ar.area_factor(i, j);
    }
    EXPECT_NEAR(row, 1.0, 1e-12);
  }
}

class AlignedCube : public ::testing::TestWithParam<int> {};

TEST_P(AlignedCube, EveryPairMatchesTheLongDoubleReference) {
  const int n = GetParam();
  const PatchMesh mesh = cube_mesh(n);
  const AlignedRectangles ar(mesh);
  EXPECT_EQ(ar.summary().rectangles, 6 * n * n);
  EXPECT_EQ(ar.summary().frames, 1);
  EXPECT_EQ(ar.summary().planes, 6);
  EXPECT_EQ(ar.summary().tables_interval, 15);  // 3 parallel + 12 perpendicular plane pairs
  const Comparison c = compare_all(mesh, ar);
  EXPECT_TRUE(c.all_eligible);
  EXPECT_TRUE(c.reciprocal);
  EXPECT_LE(c.max_rel, 1e-12);
  EXPECT_LE(c.max_abs_small, 1e-18);
  EXPECT_LE(c.max_row, 1e-12);
  std::printf("cube %d x %d: max rel error vs reference (F > 1e-6) %.3g, max |row sum - 1| %.3g, tables %zu bytes\n", n,
              n, c.max_rel, c.max_row, ar.table_bytes());
}

INSTANTIATE_TEST_SUITE_P(AlignedRectangles, AlignedCube, ::testing::Values(4, 8));

TEST(AlignedRectangles, DirectEvaluationAndEveryBudgetGiveTheSameBits) {
  const PatchMesh mesh = cube_mesh(8);
  const AlignedRectangles full(mesh);
  const AlignedRectangles none(mesh, 0);
  EXPECT_EQ(none.table_bytes(), 0u);
  EXPECT_EQ(none.summary().tables_interval + none.summary().tables_corner, 0);
  const AlignedRectangles some(mesh, 5 * full.table_bytes() / 12);
  EXPECT_LE(some.table_bytes(), 5 * full.table_bytes() / 12);
  EXPECT_GT(some.summary().tables_interval, 0);
  EXPECT_LT(some.summary().tables_interval, 15);
  long long differ = 0;
  for (int i = 0; i < mesh.size(); ++i)
    for (int j = 0; j < mesh.size(); ++j) {
      const double a = full.area_factor(i, j);
      differ += a != none.area_factor(i, j);
      differ += a != some.area_factor(i, j);
    }
  EXPECT_EQ(differ, 0);
}

TEST(AlignedRectangles, ConcurrentCallsGiveTheSerialValues) {
  const PatchMesh mesh = cube_mesh(8);
  const AlignedRectangles ar(mesh);
  const int n = mesh.size();
  std::vector<double> serial(size_t(n) * n), parallel(size_t(n) * n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) serial[size_t(i) * n + j] = ar.area_factor(i, j);
#pragma omp parallel for schedule(dynamic, 1)
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) parallel[size_t(i) * n + j] = ar.area_factor(j, i);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) ASSERT_EQ(serial[size_t(i) * n + j], parallel[size_t(j) * n + i]);
}

// A closed box room on an irregular lattice (one set of non-uniform lines per world axis), each
// wall tiled like brickwork: rows one cell high, bricks 1–3 cells long with the joints of every
// row at random. Many distinct intervals per wall, so the 16-read corner tables are used.
TEST(AlignedRectangles, BrickworkRoomWithNonUniformCoordinates) {
  const double L[3] = {1.3, 0.7, 1.1};
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> U(0.3, 1.0);
  std::uniform_int_distribution<int> brick(1, 3);
  std::vector<double> lines[3];
  const int cells[3] = {12, 7, 10};
  for (int a = 0; a < 3; ++a) {
    lines[a] = {0.0};
    for (int k = 0; k < cells[a]; ++k) lines[a].push_back(lines[a].back() + U(rng));
    for (double& v : lines[a]) v *= L[a] / lines[a].back();
    lines[a].back() = L[a];
  }
  PatchMesh mesh;
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      for (int r = 0; r < cells[v]; ++r)
        for (int k = 0; k < cells[u];) {
          const int k1 = std::min(cells[u], k + brick(rng));
          add_rect(mesh, axis, side ? -1 : 1, side ? L[axis] : 0.0, lines[u][k], lines[u][k1], lines[v][r],
                   lines[v][r + 1]);
          k = k1;
        }
    }
  const AlignedRectangles ar(mesh);
  EXPECT_EQ(ar.summary().rectangles, mesh.size());
  EXPECT_EQ(ar.summary().planes, 6);
  EXPECT_GT(ar.summary().tables_corner, 0);
  const Comparison c = compare_all(mesh, ar);
  EXPECT_TRUE(c.all_eligible);
  EXPECT_TRUE(c.reciprocal);
  EXPECT_LE(c.max_rel, 1e-12);
  EXPECT_LE(c.max_row, 1e-12);
  // Same bits without tables.
  const AlignedRectangles none(mesh, 0);
  for (int i = 0; i < mesh.size(); ++i)
    for (int j = 0; j < mesh.size(); ++j) ASSERT_EQ(ar.area_factor(i, j), none.area_factor(i, j));
  std::printf("brickwork room (%d patches, %d interval + %d corner tables): max rel error %.3g, max |row - 1| %.3g\n",
              mesh.size(), ar.summary().tables_interval, ar.summary().tables_corner, c.max_rel, c.max_row);
}

TEST(AlignedRectangles, RotatedAndShiftedCubeGivesTheSameFactors) {
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  const PatchMesh aligned = cube_mesh(8), rotated = cube_mesh(8, R, Vec3(0.3, -2.0, 5.0));
  const AlignedRectangles a(aligned), r(rotated);
  EXPECT_EQ(r.summary().rectangles, rotated.size());
  EXPECT_EQ(r.summary().frames, 1);
  EXPECT_EQ(r.summary().planes, 6);
  EXPECT_EQ(r.summary().plane_pairs_exchanging, 15);
  double worst = 0.0;
  for (int i = 0; i < aligned.size(); ++i)
    for (int j = 0; j < aligned.size(); ++j) {
      ASSERT_TRUE(r.eligible(i, j));
      const double want = a.area_factor(i, j), got = r.area_factor(i, j);
      ASSERT_EQ(got, r.area_factor(j, i));
      if (want == 0.0) ASSERT_EQ(got, 0.0) << i << "," << j;
      else worst = std::max(worst, std::abs(got - want) / want);
    }
  EXPECT_LE(worst, 1e-12);
  std::printf("rotated cube 8 x 8: max rel difference to the aligned cube %.3g\n", worst);
}

// A wall patch crossing a table top's plane, and a table top reaching behind the wall.
TEST(AlignedRectangles, StraddlingPerpendicularPairIsClippedAtTheCommonLine) {
  PatchMesh mesh;
  add_rect(mesh, 2, +1, 0.5, 0.3, 1.5, 0.0, 1.0);   // P: top z = 0.5, x ∈ [0.3, 1.5], y ∈ [0, 1], up
  add_rect(mesh, 0, -1, 1.2, 0.2, 0.8, 0.1, 0.9);   // Q: wall x = 1.2, y ∈ [0.2, 0.8], z ∈ [0.1, 0.9], facing -x
  add_rect(mesh, 0, -1, 1.2, 0.2, 0.8, 0.1, 0.45);  // wholly below the top
  add_rect(mesh, 2, +1, 0.5, 1.3, 1.5, 0.0, 1.0);   // top wholly behind the wall
  const AlignedRectangles ar(mesh);
  ASSERT_TRUE(ar.eligible(0, 1));
  const double got = ar.area_factor(0, 1);
  EXPECT_EQ(got, ar.area_factor(1, 0));
  EXPECT_EQ(ar.area_factor(0, 2), 0.0);
  EXPECT_EQ(ar.area_factor(3, 1), 0.0);
  EXPECT_EQ(ar.area_factor(1, 3), 0.0);
  // (a) the closed form on the hand-clipped rectangles: common axis y, distances from the line
  // x = 1.2, z = 0.5: on P 1.2 − x ∈ [0, 0.9], on Q z − 0.5 ∈ [0, 0.4].
  const double clipped = double(perpendicular_af(0.0, 1.0, 0.0, 0.9L, 0.2L, 0.8L, 0.0, 0.4L));
  EXPECT_NEAR(got, clipped, 1e-15 * clipped);
  // (b) brute force: ∫_P F(dA_x → Q) dA_x with Lambert's kernel (horizon clipping included), on
  // the part of P in front of Q (behind it the kernel is 0); composite Gauss graded towards the
  // line x = 1.2 and towards y = 0.2, 0.8, where the integrand is singular (t log t).
  std::vector<double> t, w;
  gauss_legendre_unit(12, t, w);
  auto graded = [&](double a, double b, bool to_a, bool to_b) {  // (point, weight) on [a, b]
    std::vector<std::pair<double, double>> edges;                // sub-interval ends
    std::vector<double> cuts = {a, b};
    const double mid = (a + b) / 2;
    for (int k = 1; k <= 24; ++k) {
      const double g = std::pow(0.25, k);
      if (to_a) cuts.push_back(a + (mid - a) * g);
      if (to_b) cuts.push_back(b - (b - mid) * g);
    }
    if (to_a || to_b) cuts.push_back(mid);
    std::sort(cuts.begin(), cuts.end());
    std::vector<std::pair<double, double>> out;
    for (size_t c = 0; c + 1 < cuts.size(); ++c)
      for (size_t q = 0; q < t.size(); ++q)
        out.emplace_back(cuts[c] + (cuts[c + 1] - cuts[c]) * t[q], (cuts[c + 1] - cuts[c]) * w[q]);
    return out;
  };
  Vec3 src[4];
  mesh.polygon(1, src);
  const auto xs = graded(0.3, 1.2, false, true);
  std::vector<std::pair<double, double>> ys;
  for (auto seg : {std::make_pair(0.0, 0.2), std::make_pair(0.2, 0.8), std::make_pair(0.8, 1.0)}) {
    const bool to_a = seg.first == 0.2 || seg.first == 0.8, to_b = seg.second == 0.2 || seg.second == 0.8;
    const auto g = graded(seg.first, seg.second, to_a, to_b);
    ys.insert(ys.end(), g.begin(), g.end());
  }
  ld brute = 0;
  for (const auto& [x, wx] : xs)
    for (const auto& [y, wy] : ys)
      brute += ld(wx) * wy * lambert_form_factor(Receiver{Vec3(x, y, 0.5), Vec3::UnitZ()}, src, 4);
  EXPECT_NEAR(got, double(brute), 1e-9 * got);
  std::printf("straddling pair: A F = %.17g, hand-clipped closed form %.17g, Lambert quadrature %.17g (rel %.2g)\n",
              got, clipped, double(brute), std::abs(got - double(brute)) / got);
}

// The same pair cut into 5 × 5 grids whose middle row / column straddles the other plane: the
// sub-pair factors add up to the whole pair's (additivity of A F), with tables (interval form;
// corner form when the whole rectangles share the planes) and without.
TEST(AlignedRectangles, StraddlingGridsAddUpToTheWholePair) {
  auto grid = [](PatchMesh& m, int axis, int sign, double off, double u0, double u1, double v0, double v1) {
    for (int a = 0; a < 5; ++a)
      for (int b = 0; b < 5; ++b)
        add_rect(m, axis, sign, off, u0 + (u1 - u0) * a / 5, u0 + (u1 - u0) * (a + 1) / 5, v0 + (v1 - v0) * b / 5,
                 v0 + (v1 - v0) * (b + 1) / 5);
  };
  // Without the whole rectangles the wall spans y ∈ [0, 1] like the top (interval tables); with
  // them it spans y ∈ [0.2, 0.8] (corner tables).
  for (bool with_whole : {false, true}) {
    const double y0 = with_whole ? 0.2 : 0.0, y1 = with_whole ? 0.8 : 1.0;
    const double whole = double(perpendicular_af(0.0, 1.0, 0.0, 0.9L, y0, y1, 0.0, 0.4L));
    PatchMesh mesh;
    if (with_whole) {
      add_rect(mesh, 2, +1, 0.5, 0.3, 1.5, 0.0, 1.0);
      add_rect(mesh, 0, -1, 1.2, y0, y1, 0.1, 0.9);
    }
    const int p0 = mesh.size();
    grid(mesh, 2, +1, 0.5, 0.3, 1.5, 0.0, 1.0);  // x cells of 0.24: 1.2 inside [1.02, 1.26]
    const int q0 = mesh.size();
    grid(mesh, 0, -1, 1.2, y0, y1, 0.1, 0.9);  // z cells of 0.16: 0.5 inside [0.42, 0.58]
    const AlignedRectangles ar(mesh), none(mesh, 0);
    EXPECT_EQ(ar.summary().tables_interval + ar.summary().tables_corner, 1);
    EXPECT_EQ(ar.summary().tables_corner, with_whole ? 1 : 0);
    ld sum = 0;
    for (int i = p0; i < p0 + 25; ++i)
      for (int j = q0; j < q0 + 25; ++j) {
        const double a = ar.area_factor(i, j);
        ASSERT_EQ(a, none.area_factor(i, j));
        ASSERT_EQ(a, ar.area_factor(j, i));
        ASSERT_GE(a, 0.0);
        sum += a;
      }
    EXPECT_NEAR(double(sum), whole, 1e-14 * whole);
    if (with_whole) {
      EXPECT_EQ(ar.area_factor(0, 1), none.area_factor(0, 1));
      EXPECT_NEAR(ar.area_factor(0, 1), whole, 1e-15 * whole);
    }
  }
}

TEST(AlignedRectangles, TrianglesSkewQuadsAndOtherFramesAreNotEligible) {
  PatchMesh mesh;
  add_rect(mesh, 2, +1, 0.0, 0.0, 1.0, 0.0, 1.0);                        // 0: floor
  add_rect(mesh, 0, -1, 1.0, 0.0, 1.0, 0.0, 1.0);                        // 1: wall
  add_polygon(mesh, {{0, 0, 1}, {0, 1, 1}, {1, 0, 1}});                  // 2: triangle
  add_polygon(mesh, {{0, 0, 1}, {0, 1, 1}, {1, 1.2, 1}, {1, -0.2, 1}});  // 3: trapezoid
  add_polygon(mesh, {{0, 0, 1}, {0.3, 1, 1}, {1.3, 1, 1}, {1, 0, 1}});   // 4: parallelogram
  const double c = std::cos(0.3), s = std::sin(0.3);
  add_polygon(mesh, {{0, 0, 1}, {-s, c, 1}, {c - s, s + c, 1}, {c, s, 1}});  // 5: rotated square
  add_polygon(mesh, {{0, 0, 2}, {0, 1, 2}, {1, 1, 2}, {1, 0, 2 + 1e-6}});    // 6: non-planar
  add_rect(mesh, 1, +1, 0.0, 0.0, 1.0, 0.0, 1.0);                            // 7: wall y = 0
  const AlignedRectangles ar(mesh);
  EXPECT_TRUE(ar.eligible(0, 1));
  EXPECT_TRUE(ar.eligible(0, 7));
  EXPECT_TRUE(ar.eligible(0, 0));
  for (int k : {2, 3, 4, 6}) {
    EXPECT_FALSE(ar.is_rectangle(k)) << k;
    EXPECT_FALSE(ar.eligible(0, k)) << k;
    EXPECT_FALSE(ar.eligible(k, 0)) << k;
  }
  EXPECT_TRUE(ar.is_rectangle(5));  // a rectangle, of another frame
  EXPECT_FALSE(ar.eligible(0, 5));
  EXPECT_TRUE(ar.eligible(5, 5));
  EXPECT_TRUE(std::isnan(ar.area_factor(0, 5)));
  EXPECT_EQ(ar.summary().frames, 2);
  EXPECT_EQ(ar.area_factor(0, 0), 0.0);
}

// aligned_rectangle_pair (one pair, no mesh: the hierarchical method's links) against the
// class on every ordered pair of meshes that exercise each path: the brickwork room (non-uniform
// coordinates, parallel and perpendicular), the rotated cube (a frame not the world's), the
// straddling pair (clipped at the common line, and wholly behind). The class merges coordinates
// closer than 1e-12 of the mesh's size; these meshes have none, so the two agree to rounding.
TEST(AlignedRectangles, OnePairWithoutAMeshGivesTheClassValue) {
  auto brickwork = [] {
    PatchMesh mesh;
    const double cuts[4] = {0.0, 0.37, 0.81, 1.3};
    for (int axis = 0; axis < 3; ++axis)
      for (int side = 0; side < 2; ++side)
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b)
            add_rect(mesh, axis, side ? -1 : 1, side ? 1.3 : 0.0, cuts[a], cuts[a + 1], cuts[b], cuts[b + 1]);
    return mesh;
  };
  PatchMesh straddling;
  add_rect(straddling, 2, +1, 0.5, 0.3, 1.5, 0.0, 1.0);
  add_rect(straddling, 0, -1, 1.2, 0.2, 0.8, 0.1, 0.9);
  add_rect(straddling, 0, -1, 1.2, 0.2, 0.8, 0.1, 0.45);
  add_rect(straddling, 2, +1, 0.5, 1.3, 1.5, 0.0, 1.0);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  for (const PatchMesh& mesh : {brickwork(), cube_mesh(4, R, Vec3(0.3, -2.0, 5.0)), straddling}) {
    const AlignedRectangles ar(mesh);
    double worst = 0.0;
    int zeros = 0;
    for (int i = 0; i < mesh.size(); ++i)
      for (int j = 0; j < mesh.size(); ++j) {
        if (i == j) continue;
        Vec3 p[4], q[4];
        mesh.polygon(i, p);
        mesh.polygon(j, q);
        double got = -1.0;
        ASSERT_TRUE(aligned_rectangle_pair(p, mesh.patches[i].normal, q, mesh.patches[j].normal, got)) << i << "," << j;
        const double want = ar.area_factor(i, j);
        if (want == 0.0) {
          ASSERT_EQ(got, 0.0) << i << "," << j;
          ++zeros;
        } else {
          worst = std::max(worst, std::abs(got - want) / want);
        }
      }
    EXPECT_LE(worst, 1e-13) << mesh.size() << " patches";
    EXPECT_GT(zeros, 0);
  }
}

TEST(AlignedRectangles, OnePairRefusesWhatTheClassDoesNotTake) {
  const Vec3 floor[4] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  const Vec3 up = Vec3::UnitZ();
  const double c = std::cos(0.3), s = std::sin(0.3);
  const Vec3 rotated[4] = {{0, 0, 1}, {c, s, 1}, {c - s, s + c, 1}, {-s, c, 1}};  // another frame
  const Vec3 parallelogram[4] = {{0, 0, 1}, {1, 0, 1}, {1.3, 1, 1}, {0.3, 1, 1}};
  const Vec3 clockwise[4] = {{0, 0, 1}, {0, 1, 1}, {1, 1, 1}, {1, 0, 1}};  // wound against its normal
  double af = 7.0;
  EXPECT_FALSE(aligned_rectangle_pair(floor, up, rotated, up, af));
  EXPECT_FALSE(aligned_rectangle_pair(floor, up, parallelogram, up, af));
  EXPECT_FALSE(aligned_rectangle_pair(floor, up, clockwise, up, af));
  EXPECT_FALSE(aligned_rectangle_pair(parallelogram, up, floor, up, af));
  EXPECT_EQ(af, 7.0);  // nothing written
  // The unit squares a distance 1 apart, facing: Howell C-11 (refs C11_unit_squares_c1).
  const Vec3 ceiling[4] = {{0, 0, 1}, {0, 1, 1}, {1, 1, 1}, {1, 0, 1}};
  ASSERT_TRUE(aligned_rectangle_pair(floor, up, ceiling, -up, af));
  EXPECT_NEAR(af, 0.19982489569838738, 1e-15);
  const Vec3 facing_up[4] = {{0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  ASSERT_TRUE(aligned_rectangle_pair(floor, up, facing_up, up, af));  // its back to the floor
  EXPECT_EQ(af, 0.0);
  ASSERT_TRUE(aligned_rectangle_pair(ceiling, -up, floor, up, af));  // reciprocity: equal areas
  EXPECT_NEAR(af, 0.19982489569838738, 1e-15);
  // Sharing an edge at right angles: Howell C-14 (refs cube_floor_to_wall).
  const Vec3 wall[4] = {{1, 0, 0}, {1, 0, 1}, {1, 1, 1}, {1, 1, 0}};
  ASSERT_TRUE(aligned_rectangle_pair(floor, up, wall, -Vec3::UnitX(), af));
  EXPECT_NEAR(af, 0.20004377607540315, 1e-15);
}

// The figures at production sizes: the rows of a sample of patches against the long-double
// reference (same formula, term by term, other summation order), and a sample of far pairs
// against 8^4 Gauss (the true error of the 16-term sum in long double). The error of A F is
// about 1e-19 d² (the size of the terms), so it is the relative error of small factors that
// grows: reported for F > 1e-6, and as the largest absolute error of F over all sampled pairs.
TEST(AlignedRectangles, AccuracyAt32And64PerWall) {
  for (int n : {32, 64}) {
    const PatchMesh mesh = cube_mesh(n);
    const AlignedRectangles ar(mesh);
    const int N = mesh.size();
    std::vector<Box> boxes;
    for (int i = 0; i < N; ++i) boxes.push_back(box_of(mesh, i));
    std::mt19937_64 rng(11);
    std::uniform_int_distribution<int> pick(0, N - 1);
    double max_rel = 0.0, max_abs = 0.0, max_row = 0.0, far_rel = 0.0, far_abs = 0.0;
    std::vector<double> rel;
    const int rows = n == 32 ? 24 : 8;
    for (int s = 0; s < rows; ++s) {
      const int i = pick(rng);
      const double A = mesh.patches[i].area;
      ld row = 0;
      for (int j = 0; j < N; ++j) {
        const double got = ar.area_factor(i, j);
        row += got;
        if (i == j) continue;
        const ld want = reference(boxes[i], boxes[j]);
        max_abs = std::max(max_abs, double(std::abs(got - want) / A));
        if (want / A > 1e-6) {
          rel.push_back(double(std::abs(got - want) / want));
          max_rel = std::max(max_rel, rel.back());
        }
      }
      max_row = std::max(max_row, double(std::abs(row / A - 1)));
    }
    std::sort(rel.begin(), rel.end());
    // Far pairs (centroids at least 8 patch sizes apart), true error.
    int far = 0, far_big = 0;
    while (far < 200) {
      const int i = pick(rng), j = pick(rng);
      if ((mesh.patches[i].centroid - mesh.patches[j].centroid).norm() < 8.0 / n) continue;
      const double got = ar.area_factor(i, j);
      if (got == 0.0) continue;
      const ld want = gauss_far(mesh, i, j, 8);
      far_abs = std::max(far_abs, double(std::abs(got - want) / mesh.patches[i].area));
      if (want / mesh.patches[i].area > 1e-6) {
        far_rel = std::max(far_rel, double(std::abs(got - want) / want));
        ++far_big;
      }
      ++far;
    }
    EXPECT_LE(max_rel, n == 32 ? 1e-11 : 1e-10);
    EXPECT_LE(far_rel, n == 32 ? 1e-11 : 1e-10);
    EXPECT_LE(std::max(max_abs, far_abs), 1e-15);
    EXPECT_LE(max_row, 1e-12);
    std::printf(
        "cube %d x %d, %d sampled rows (%zu pairs with F > 1e-6) vs long-double reference: max rel %.3g, "
        "median %.3g, 99%% %.3g, max |F error| %.3g; 200 far pairs vs 8^4 Gauss: max rel (%d with F > 1e-6) "
        "%.3g, max |F error| %.3g; max |row - 1| %.3g; tables %.1f MB\n",
        n, n, rows, rel.size(), max_rel, rel[rel.size() / 2], rel[rel.size() * 99 / 100], max_abs, far_big, far_rel,
        far_abs, max_row, ar.table_bytes() / 1e6);
  }
}
