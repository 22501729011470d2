// The numerical-stability cases (docs/kernels.md "Stability table"), each with an independent
// expected value: a closed form (Howell B-3 / B-4) in long double, Lambert's formula in long double
// on the same double inputs (80-bit, clipped in long double), or tests/data/refs_public.json. Every
// exact kernel is checked.
#include <gtest/gtest.h>

#include "kernels/lambert_batch.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "kernels/kernels.h"
#include "refs.h"

using namespace photometria;

namespace {

using LD = long double;
using LVec = Eigen::Matrix<long double, 3, 1>;
const Kernel kExact[] = {Kernel::Iwanicki, Kernel::Lambert, Kernel::StarkVertex, Kernel::StarkImage};

// Howell B-3: receiver under the corner of a parallel a × b rectangle at distance c.
LD howell_b3(LD a, LD b, LD c) {
  const LD X = a / c, Y = b / c, sx = std::sqrt(1 + X * X), sy = std::sqrt(1 + Y * Y);
  return (X / sx * std::atan(Y / sx) + Y / sy * std::atan(X / sy)) / (2 * M_PIl);
}
// Howell B-4: perpendicular rectangle, height a, width b along the edge in the receiver plane,
// receiver at distance c on the normal through its corner.
LD howell_b4(LD a, LD b, LD c) {
  const LD X = a / b, Y = c / b, r = std::sqrt(X * X + Y * Y);
  return (std::atan(1 / Y) - Y / r * std::atan(1 / r)) / (2 * M_PIl);
}

// Lambert (M. M. Stark, "Vertex-Based Formulations of Irradiance from Polygonal Sources", Utah
// UUCS-00-012, 2000, eq. 3) in long double after clipping to the receiver's half-space; the
// receiver must see the polygon's front and not lie in its plane.
LD lambert_ld(const Vec3& p, const Vec3& normal, const Polygon& poly) {
  const LVec N = normal.cast<LD>();
  std::vector<LVec> a, c;
  for (const Vec3& v : poly) a.push_back(v.cast<LD>() - p.cast<LD>());
  for (size_t i = 0; i < a.size(); ++i) {
    const LVec& A = a[i];
    const LVec& B = a[(i + 1) % a.size()];
    const LD ha = N.dot(A), hb = N.dot(B);
    if (ha >= 0) c.push_back(A);
    if ((ha > 0 && hb < 0) || (ha < 0 && hb > 0)) c.push_back(A + ha / (ha - hb) * (B - A));
  }
  LD sum = 0;
  for (size_t i = 0; c.size() >= 3 && i < c.size(); ++i) {
    const LVec& A = c[i];
    const LVec& B = c[(i + 1) % c.size()];
    const LVec x = A.cross(B - A);
    const LD len = x.norm();
    if (len == 0) continue;
    sum += std::atan2(len, A.dot(B)) * N.dot(x) / len;
  }
  return -sum / (2 * M_PIl);
}

void expect_all(const Receiver& r, const Polygon& poly, LD want, double rel, const std::string& what) {
  for (Kernel k : kExact) {
    const double f = point_form_factor(k, r, poly);
    ASSERT_TRUE(std::isfinite(f)) << what << " / " << kernel_info(k).name;
    if (want == 0) EXPECT_EQ(f, 0.0) << what << " / " << kernel_info(k).name;
    else
      EXPECT_LE(std::abs((f - want) / want), rel)
          << what << " / " << kernel_info(k).name << ": " << f << " vs " << double(want);
  }
}

Polygon parallel_rect(double x0, double y0, double x1, double y1, double z) {  // front faces −z
  return {{x0, y1, z}, {x1, y1, z}, {x1, y0, z}, {x0, y0, z}};
}
Polygon wall_x(double x, double y0, double y1, double z0, double z1) {  // plane x, front faces −x
  return {{x, y0, z1}, {x, y1, z1}, {x, y1, z0}, {x, y0, z0}};
}

const Receiver up{Vec3::Zero(), Vec3::UnitZ()};

}  // namespace

// A unit square 1e6 sizes away: F ≈ 1.6e-13. Required: relative error <= 1e-10 (acos loses all).
// The centred evaluations (iwanicki, stark-vertex, stark-image: every term of the order of F,
// docs/kernels.md "Accuracy") keep full precision; Lambert's plain edge sum keeps ~10 digits.
TEST(Stability, TinySolidAngle) {
  const Kernel centred[] = {Kernel::Iwanicki, Kernel::StarkVertex, Kernel::StarkImage};
  const LD want = howell_b3(1, 1, 1e6L);
  const Polygon sq = parallel_rect(0, 0, 1, 1, 1e6);
  for (Kernel k : centred) EXPECT_LE(std::abs(point_form_factor(k, up, sq) / want - 1), 1e-14) << kernel_info(k).name;
  EXPECT_LE(std::abs(point_form_factor(Kernel::Lambert, up, sq) / want - 1), 1e-10);
  // General position: tilted receiver, oblique quad 1e6 away (long double Lambert on the same inputs).
  const Vec3 n = Vec3(0.36, 0.48, 0.8);
  const Vec3 c = 1e6 * Vec3(0.3, 0.2, 0.9).normalized();
  const Vec3 u = Vec3(0.9, -0.1, 0.3), w = Vec3(-0.2, 0.7, -0.15);
  const Polygon far = {c, c + u, c + u + w, c + w};
  const Polygon q = c.dot(u.cross(w)) < 0 ? far : Polygon{far.rbegin(), far.rend()};  // face the receiver
  const LD ref = lambert_ld(Vec3::Zero(), n, q);
  ASSERT_GT(ref, 1e-14L);
  for (Kernel k : centred)
    EXPECT_LE(std::abs(point_form_factor(k, {Vec3::Zero(), n}, q) / ref - 1), 1e-13) << kernel_info(k).name;
  EXPECT_LE(std::abs(point_form_factor(Kernel::Lambert, {Vec3::Zero(), n}, q) / ref - 1), 1e-9);
}

// The far-field ladder: a triangle, an oblique quad and a non-convex pentagon at 10 … 1e6 sizes,
// seen by a tilted receiver, the configuration also shifted by 1e6 (dyadic offset: exactly the
// same geometry). Reference: Lambert in long double on the same inputs (80-bit; its own rounding
// is ~5e-20·distance/size, below 1e-13 here). Every exact kernel within 1e-12 relative, except
// lambert's plain edge sum, whose error grows like ε·distance/size (docs/kernels.md): held to
// 1e-12 up to 1e3 sizes and to 32 ε·distance/size beyond.
TEST(Stability, FarFieldLadder) {
  const Vec3 n = Vec3(0.36, -0.48, 0.8);
  const Vec3 dir = Vec3(0.3, 0.2, 0.9).normalized();
  const Vec3 t1 = dir.unitOrthogonal(), t2 = dir.cross(t1);
  const std::vector<std::vector<std::array<double, 2>>> shapes = {
      {{0, 0}, {1, 0.1}, {0.3, 0.9}},
      {{0, 0}, {0.9, -0.2}, {1.1, 0.7}, {0.1, 0.8}},
      {{0, 0}, {1, 0}, {0.6, 0.3}, {1, 1}, {0, 1}}};  // non-convex (reflex vertex at (0.6, 0.3))
  const Vec3 offset(0x1p20, -0x1p19, 0x1p20);
  for (const auto& shape : shapes) {
    for (int e = 1; e <= 6; ++e) {
      const double D = std::pow(10.0, e);
      // Tilt the polygon's plane 30° away from facing the receiver.
      const Vec3 a1 = std::cos(0.5) * t1 + std::sin(0.5) * dir, a2 = t2;
      Polygon poly;
      for (const auto& xy : shape) poly.push_back(D * dir + xy[0] * a1 + xy[1] * a2);
      if (newell_vector(poly).dot(dir) > 0) std::reverse(poly.begin(), poly.end());  // face the receiver
      // Dyadic coordinates, so that the 1e6 shift below is exact.
      for (Vec3& v : poly)
        for (int k = 0; k < 3; ++k) v[k] = std::ldexp(std::round(std::ldexp(v[k], 30)), -30);
      Polygon moved;
      for (const Vec3& v : poly) moved.push_back(v + offset);
      const LD ref = lambert_ld(Vec3::Zero(), n, poly);
      ASSERT_GT(ref, 0.0L);
      for (Kernel k : kExact) {
        const double tol = k == Kernel::Lambert && D > 1e3 ? 32 * 2.2e-16 * D : 1e-12;
        for (const bool shifted : {false, true}) {
          const double f =
              shifted ? point_form_factor(k, {offset, n}, moved) : point_form_factor(k, {Vec3::Zero(), n}, poly);
          EXPECT_LE(std::abs(f / ref - 1), tol)
              << kernel_info(k).name << " at " << D << " sizes, " << poly.size() << " vertices"
              << (shifted ? ", shifted" : "") << ": " << f << " vs " << double(ref);
        }
      }
    }
  }
}

TEST(Stability, ReceiverNearThePolygonPlaneAnEdgeAndAVertex) {
  // 1e-12 below a parallel square's corner (near its plane and its vertex): F -> 1/4.
  expect_all(up, parallel_rect(0, 0, 1, 1, 1e-12), howell_b3(1, 1, 1e-12L), 1e-12, "1e-12 under a corner");
  // 1e-12 below the middle: four corners, F -> 1.
  expect_all(up, parallel_rect(-0.5, -0.5, 0.5, 0.5, 1e-12), 4 * howell_b3(0.5L, 0.5L, 1e-12L), 1e-12,
             "1e-12 under the centre");
  // 1e-12 in front of a perpendicular wall's bottom edge, at its corner and at its middle.
  expect_all(up, wall_x(1e-12, 0, 1, 0, 1), howell_b4(1, 1, 1e-12L), 1e-12, "1e-12 from the corner of an edge");
  expect_all(up, wall_x(1e-12, -0.5, 0.5, 0, 1), 2 * howell_b4(1, 0.5L, 1e-12L), 1e-12,
             "1e-12 from the middle of an edge");
  // refs: 1e-6 from the middle of an edge.
  const auto& c = refs::find("pp_B4_mid_edge_c1e-6");
  expect_all(up, refs::polygon(c["geometry"]["polygon"]), refs::number(c["value"]), 1e-12, "pp_B4_mid_edge_c1e-6");
}

TEST(Stability, ReceiverExactlyOnAnEdgeOrAVertex) {
  // The limit from the front: a wall standing on the receiver plane fills half the hemisphere seen
  // from its bottom edge, a quarter from its corner (B-4 with c -> 0: atan(∞)/(2π) = 1/4).
  expect_all(up, wall_x(0, -0.5, 0.5, 0, 1), 0.5L, 1e-15, "on the edge");
  expect_all(up, wall_x(0, 0, 1, 0, 1), 0.25L, 1e-15, "on the corner");
  // and a polygon inclined at 45° through the edge: the limit is the wedge (1 − cos 45°)/2.
  expect_all({Vec3(0.5, 0, 0), Vec3::UnitZ()}, Polygon{{0, 0, 0}, {1, 0, 0}, {1, 1, 1}, {0, 1, 1}},
             (1 - std::sqrt(0.5L)) / 2, 1e-15, "on the edge of a 45-degree polygon");
}

TEST(Stability, HorizonCases) {
  // Straddling, a vertex exactly on the plane: refs.
  for (const char* id : {"pp_straddle_vertical_rect", "pp_straddle_tilted_triangle_general", "pp_vertex_on_horizon",
                         "pp_edge_on_plane_through_point", "pp_fully_below_horizon"}) {
    const auto& c = refs::find(id);
    const auto& g = c["geometry"];
    const Receiver r{refs::vec(g["receiver"]["point"]), refs::vec(g["receiver"]["normal"]).normalized()};
    const LD want = refs::number(c["value"]);
    for (Kernel k : kExact) {
      const double f = point_form_factor(k, r, refs::polygon(g["polygon"]));
      if (want == 0) EXPECT_LE(std::abs(f), 1e-15) << id << " / " << kernel_info(k).name;
      else EXPECT_LE(std::abs(f / want - 1), 1e-12) << id << " / " << kernel_info(k).name;
    }
  }
  // A polygon lying in the receiver plane: F = 0 (inside it and beside it).
  expect_all({Vec3(0.2, 0.1, 0), Vec3::UnitZ()}, parallel_rect(-1, -1, 1, 1, 0), 0.0L, 0, "in the receiver plane");
  expect_all({Vec3(3, 0, 0), Vec3::UnitZ()}, Polygon{{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}}, 0.0L, 0,
             "beside");
  // A grazing polygon: its plane z = tan(1e-7)(x − 1) passes 1e-7 rad beside the receiver, which
  // faces it (N = +x), so it is seen nearly edge-on: F ≈ 1.1e-8. Reference: Lambert's formula in
  // 50-digit mpmath on the same double inputs (long double would keep only ~12 digits here).
  const double t = std::tan(1e-7);
  const Polygon graze = {{1, -0.5, 0}, {2, -0.5, t}, {2, 0.5, t}, {1, 0.5, 0}};
  expect_all({Vec3::Zero(), Vec3::UnitX()}, graze, 1.08594052461748815349208039132e-8L, 1e-12, "grazing 1e-7 rad");
}

// Receiver 2^-30 (~1e-9) and 2^-43 (~1e-13) below the middle of an edge of a parallel polygon:
// the edge subtends θ -> π, where the normal of two nearly opposite unit vectors is lost. The
// coordinates are dyadic so that v_i − p is exact and the long double reference sees exactly the
// same geometry (otherwise the rounding of v_i − p alone moves F by ~ε/distance: F varies like
// atan(x/h) beside an edge).
TEST(Stability, NearAntipodalEdgeDirections) {
  const Vec3 n = Vec3(0, 0.6, 0.8);
  const Polygon quad = {{0, 0, 1}, {0, 1, 1}, {1, 1, 1}, {1, 0, 1}};  // front faces −z
  for (double eps : {std::ldexp(1.0, -30), std::ldexp(1.0, -43)}) {
    for (const Vec3& p : {Vec3(0.5, -eps, 1 - eps), Vec3(0.5, eps, 1 - eps), Vec3(0.5, 0.0, 1 - eps)}) {
      const LD ref = lambert_ld(p, n, quad);
      ASSERT_GT(ref, 0.01L);
      expect_all({p, n}, quad, ref, 1e-12, "near edge, eps " + std::to_string(eps) + " y " + std::to_string(p.y()));
    }
  }
}

// A receiver ~1e-12 from a vertex of a quad in general position, every coordinate on a 2^-40 grid
// so that every v_i − p is exact: F is then determined to full precision by the inputs (the
// reference is Lambert in long double with the edge normals a_i × a_{i+1}, accurate here). Every
// exact kernel forms its edge normals on the shorter of a_i, a_{i+1} (a_i × (a_{i+1} − a_i) on
// the long side would keep only ~ε|a_i|/|a_{i+1}| of the short one's direction: up to 5e-4
// relative here) and keeps ~14 digits; so does the batched kernel of the fill.
TEST(Stability, ReceiverNearAVertexInGeneralPosition) {
  auto grid = [](double x) { return std::ldexp(std::round(std::ldexp(x, 40)), -40); };
  Polygon quad = {{0.35534122303499893, 0.019355918332726485, -0.41764854617001668},
                  {-0.1062149964328388, 0.67173593124483533, 0.040215982067596467},
                  {-0.32418693814133009, 0.83119693161355857, -0.78093992111709198},
                  {0.0067525336452922552, 0.40393456727091787, -0.82655865923272476}};
  for (Vec3& v : quad)
    for (int k = 0; k < 3; ++k) v[k] = grid(v[k]);
  const Vec3 N = Vec3(0.87303874977564966, 0.34719285004573591, -0.3424331559111789).normalized();
  const Vec3 front = newell_vector(quad).normalized();
  int checked = 0;
  for (const Vec3& step : {Vec3(-0.5, 0.5, 0.2), Vec3(0.3, 0.4, 0.9), Vec3(-0.7, -0.1, 0.4)}) {
    for (double size : {1e-6, 1e-9, 1e-12}) {
      const Vec3 d = size * (step - 2 * std::min(0.0, step.dot(front)) * front);  // in front of the plane
      const Vec3 p(grid(quad[1].x() + d.x()), grid(quad[1].y() + d.y()), grid(quad[1].z() + d.z()));
      const LVec Nl = N.cast<LD>();
      LD sum = 0;
      for (size_t i = 0; i < quad.size(); ++i) {
        const LVec A = (quad[i].cast<LD>() - p.cast<LD>()), B = (quad[(i + 1) % 4].cast<LD>() - p.cast<LD>());
        const LVec x = A.cross(B);
        sum += std::atan2(x.norm(), A.dot(B)) * Nl.dot(x) / x.norm();
      }
      const LD ref = -sum / (2 * M_PIl);
      ASSERT_GT(ref, 1e-4L);
      for (Kernel k : {Kernel::Iwanicki, Kernel::Lambert, Kernel::StarkVertex, Kernel::StarkImage}) {
        const double f = point_form_factor(k, {p, N}, quad);
        EXPECT_LE(std::abs(f / ref - 1), 1e-12)
            << kernel_info(k).name << " at " << size << ": " << f << " vs " << double(ref);
      }
      const PolygonBatch batch(std::vector<Polygon>{quad});
      double fb = -1.0;
      lambert_form_factors(Receiver{p, N}, batch, &fb);
      EXPECT_LE(std::abs(fb / ref - 1), 1e-12) << "batched lambert at " << size << ": " << fb << " vs " << double(ref);
      ++checked;
    }
  }
  EXPECT_EQ(checked, 9);
}

TEST(Stability, NonConvexNonPlanarRepeatedAndZeroLength) {
  const auto& l = refs::find("pp_L_shape_parallel");
  const Receiver rl{refs::vec(l["geometry"]["receiver"]["point"]), Vec3::UnitZ()};
  expect_all(rl, refs::polygon(l["geometry"]["polygon"]), refs::number(l["value"]), 1e-12, "L-shape");
  // Non-planar quad (one vertex lifted 0.3): the contour integral, long double reference.
  const Polygon bent = {{-0.5, 0.5, 1.3}, {0.5, 0.5, 1}, {0.5, -0.5, 1}, {-0.5, -0.5, 1}};
  expect_all(up, bent, lambert_ld(Vec3::Zero(), Vec3::UnitZ(), bent), 1e-12, "non-planar");
  // Repeated vertices and zero-length edges change nothing.
  const Polygon sq = parallel_rect(0, 0, 1, 1, 1);
  const Polygon rep = {sq[0], sq[0], sq[1], sq[2], sq[2], sq[2], sq[3]};
  expect_all(up, rep, howell_b3(1, 1, 1), 1e-12, "repeated vertices");
}

// Huge coordinates: the whole configuration shifted by 1e6 (dyadic values, so the shifted input is
// exactly the same geometry): the answer changes by less than 1e-12 relative.
TEST(Stability, HugeCoordinates) {
  const Vec3 off(1e6, -2e6, 3e6);
  const Vec3 n = Vec3(0.36, 0.48, 0.8);
  const Polygon quad = {{0.125, 1.25, 2.0}, {1.5, 1.75, 1.625}, {1.5, 0.75, 1.25}, {0.5, 0.25, 1.5}};
  Polygon shifted;
  for (const Vec3& v : quad) shifted.push_back(v + off);
  const Vec3 p(0.25, -0.5, 0.125);
  for (const KernelInfo& k : polygon_kernels()) {
    const double f0 = point_form_factor(k.kernel, {p, n}, quad);
    const double f1 = point_form_factor(k.kernel, {p + off, n}, shifted);
    ASSERT_GT(std::abs(f0), 0.01) << k.name;
    EXPECT_LE(std::abs(f1 / f0 - 1), 1e-12) << k.name;
  }
}
