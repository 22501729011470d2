// The batched (SIMD) Lambert kernel, lambert_batch.h, against the scalar lambert_form_factor():
// thousands of random configurations, the special cases that must take the scalar fallback
// (mixed with SIMD lanes in the same call), sub-ranges and batch sizes that are not a multiple
// of the SIMD width, and the accuracy of the SIMD atan2 it relies on.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <stdexcept>

#include "kernels/lambert_batch.h"

using namespace photometria;

namespace {

// The tolerance of the batch kernel: 1e-13 relative to the scalar value, or 1e-16 absolute
// (values whose terms cancel, e.g. F ~ 1e-12 for a far polygon, keep fewer relative digits in
// either kernel).
bool agrees(double batch, double scalar) {
  const double d = std::abs(batch - scalar);
  return d <= 1e-13 * std::abs(scalar) || d <= 1e-16;
}

struct Agreement {
  long compared = 0, nonzero = 0, scalar_calls = 0;
  double max_rel = 0.0;        // max |batch − scalar| / scalar over scalar >= 1e-3
  double max_rel_small = 0.0;  // the same over 0 < scalar < 1e-3
  double max_abs_small = 0.0;  // max |batch − scalar| over scalar < 1e-3
  void print(const char* what) const {
    std::printf(
        "[ batch    ] %s: %ld pairs, %ld nonzero, %ld scalar fallbacks; max rel diff %.2e (F >= 1e-3), "
        "%.2e rel / %.2e abs (F < 1e-3)\n",
        what, compared, nonzero, scalar_calls, max_rel, max_rel_small, max_abs_small);
  }
};

// Evaluates every polygon of `batch` for `r` both ways and checks they agree.
void compare(const Receiver& r, const PolygonBatch& batch, Agreement& a, const std::string& what) {
  std::vector<double> out(static_cast<size_t>(batch.size), -1.0);
  a.scalar_calls += lambert_form_factors(r, batch, out.data());
  Vec3 v[4];
  for (int k = 0; k < batch.size; ++k) {
    const double s = lambert_form_factor(r, v, batch.vertices(k, v));
    const double b = out[static_cast<size_t>(k)];
    ASSERT_TRUE(std::isfinite(b)) << what << " polygon " << k;
    ASSERT_GE(b, 0.0);
    ASSERT_LE(b, 1.0);
    EXPECT_TRUE(agrees(b, s)) << what << " polygon " << k << ": batch " << b << " scalar " << s << " diff " << b - s;
    ++a.compared;
    if (s == 0.0) continue;
    ++a.nonzero;
    const double rel = std::abs(b - s) / s;
    if (s >= 1e-3) a.max_rel = std::max(a.max_rel, rel);
    else a.max_rel_small = std::max(a.max_rel_small, rel), a.max_abs_small = std::max(a.max_abs_small, std::abs(b - s));
  }
}

Vec3 random_unit(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  return Vec3(g(rng), g(rng), g(rng)).normalized();
}

// A star-shaped triangle or quad (possibly non-convex) around `centre` in a random plane, radii
// in [0.2, 1.2]·size; `bend` lifts vertices off the plane (non-planar quads).
Polygon random_polygon(std::mt19937_64& rng, const Vec3& centre, int n, double size, double bend, const Vec3& normal) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const Vec3 t1 = normal.unitOrthogonal(), t2 = normal.cross(t1);
  Polygon p;
  for (int i = 0; i < n; ++i) {
    const double ang = 2 * M_PI * (i + 0.3 * unit(rng)) / n;
    const double rad = size * (0.2 + unit(rng));
    p.push_back(centre + rad * (std::cos(ang) * t1 + std::sin(ang) * t2) + bend * size * (unit(rng) - 0.5) * normal);
  }
  return p;
}

std::vector<Polygon> random_polygons(std::mt19937_64& rng, int count, const Vec3& offset) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Polygon> polys;
  for (int i = 0; i < count; ++i) {
    const Vec3 centre = offset + Vec3(2 * u(rng), 2 * u(rng), 2 * u(rng));
    polys.push_back(random_polygon(rng, centre, 3 + i % 2, 0.8, i % 4 == 0 ? 0.3 : 0.0, random_unit(rng)));
  }
  return polys;
}

// A unit cube's walls (front faces inwards), each split into m × m quads, every other one
// of them cut into two triangles.
std::vector<Polygon> cube_patches(int m) {
  std::vector<Polygon> out;
  auto wall = [&](const Vec3& o, const Vec3& u, const Vec3& w) {  // u × w points inwards
    for (int i = 0; i < m; ++i)
      for (int j = 0; j < m; ++j) {
        const Vec3 a = o + (double(i) / m) * u + (double(j) / m) * w, b = a + u / m, c = b + w / m, d = a + w / m;
        if ((i + j) % 2) out.push_back({a, b, c, d});
        else out.push_back({a, b, c}), out.push_back({a, c, d});
      }
  };
  wall({0, 0, 0}, {1, 0, 0}, {0, 1, 0});  // floor z = 0 faces +z
  wall({0, 0, 1}, {0, 1, 0}, {1, 0, 0});  // ceiling z = 1 faces −z
  wall({0, 0, 0}, {0, 0, 1}, {1, 0, 0});  // y = 0 faces +y
  wall({0, 1, 0}, {1, 0, 0}, {0, 0, 1});  // y = 1 faces −y
  wall({0, 0, 0}, {0, 1, 0}, {0, 0, 1});  // x = 0 faces +x
  wall({1, 0, 0}, {0, 0, 1}, {0, 1, 0});  // x = 1 faces −x
  return out;
}

}  // namespace

TEST(LambertBatch, UsesAvx2WhereTheCpuHasIt) {
  const std::string isa = lambert_batch_isa();
#if defined(__x86_64__)
  const bool avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  EXPECT_EQ(isa, avx2 ? "avx2" : "scalar");
#endif
  std::printf("[ batch    ] instruction set: %s\n", isa.c_str());
}

// The kernel's atan2 (lambert_batch_avx2.cpp, y >= 0 as for Θ = atan2(|a × b|, a · b)) against
// long double atan2l over every sign of x and 40 decades of y/x, exact at the axes; and
// xsimd 8.1's atan2, which the kernel does not use, for the record (≈ 2.6 ulps).
TEST(LambertBatch, SimdAtan2IsAccurateToAFewTenthsOfAnUlp) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0), decade(-20.0, 20.0), angle(0.0, M_PI);
  const int n = 400000;
  std::vector<double> y(n), x(n), got(n), with_xsimd(n);
  for (int i = 0; i < n; ++i) {
    switch (i % 5) {
      case 0: y[i] = std::abs(u(rng)), x[i] = u(rng); break;
      case 1: y[i] = std::pow(10.0, decade(rng)) * std::abs(u(rng)), x[i] = u(rng); break;
      case 2: y[i] = std::abs(u(rng)), x[i] = std::pow(10.0, decade(rng)) * u(rng); break;
      case 3: {
        const double t = angle(rng);
        y[i] = std::sin(t), x[i] = std::cos(t);
      } break;
      default: y[i] = 1e-8 * std::abs(u(rng)), x[i] = -1.0 + 1e-8 * u(rng); break;  // Θ -> π
    }
  }
  if (!lambert_batch_detail::simd_atan2(y.data(), x.data(), got.data(), n)) GTEST_SKIP() << "no AVX2 on this CPU";
  ASSERT_TRUE(lambert_batch_detail::xsimd_atan2(y.data(), x.data(), with_xsimd.data(), n));
  double max_ulp = 0.0, max_ulp_xsimd = 0.0;
  int same_as_libm = 0;
  for (int i = 0; i < n; ++i) {
    const long double ref = std::atan2(static_cast<long double>(y[i]), static_cast<long double>(x[i]));
    const double r = static_cast<double>(ref);
    const long double ulp = std::nextafter(r, std::numeric_limits<double>::infinity()) - r;
    max_ulp = std::max(max_ulp, static_cast<double>(std::abs((got[i] - ref) / ulp)));
    max_ulp_xsimd = std::max(max_ulp_xsimd, static_cast<double>(std::abs((with_xsimd[i] - ref) / ulp)));
    same_as_libm += got[i] == std::atan2(y[i], x[i]);
  }
  std::printf(
      "[ batch    ] atan2: kernel max %.2f ulp (equal to std::atan2 in %.2f%%), xsimd::atan2 max %.2f ulp, "
      "%d pairs\n",
      max_ulp, 100.0 * same_as_libm / n, max_ulp_xsimd, n);
  EXPECT_LE(max_ulp, 0.7);
  EXPECT_GE(same_as_libm, 0.98 * n);
  const double ys[] = {0.0, 0.0, 1.0, 2.5, 1e-300, 1.0, 1e300};
  const double xs[] = {2.0, -2.0, 0.0, -0.0, 1.0, 1.0, 1e-300};
  double axes[7];
  ASSERT_TRUE(lambert_batch_detail::simd_atan2(ys, xs, axes, 7));
  EXPECT_EQ(axes[0], 0.0);
  EXPECT_EQ(axes[1], M_PI);
  EXPECT_EQ(axes[2], M_PI / 2);
  EXPECT_EQ(axes[3], M_PI / 2);
  EXPECT_EQ(axes[4], 1e-300);
  EXPECT_EQ(axes[5], M_PI / 4);
  EXPECT_EQ(axes[6], M_PI / 2);
}

// Random triangles and quads (planar and bent, convex or not) against random receivers: every
// relation occurs — in front, behind, straddling the horizon, wholly below it.
TEST(LambertBatch, AgreesWithTheScalarKernelOnRandomConfigurations) {
  std::mt19937_64 rng(20260101);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const PolygonBatch batch(random_polygons(rng, 1499, Vec3::Zero()));  // 1499: not a multiple of 4 or 8
  ASSERT_EQ(batch.size, 1499);
  ASSERT_EQ(batch.padded % PolygonBatch::kPadding, 0);
  Agreement a;
  for (int i = 0; i < 300; ++i)
    compare({Vec3(u(rng), u(rng), u(rng)), random_unit(rng)}, batch, a, "random " + std::to_string(i));
  a.print("random");
  EXPECT_GT(a.nonzero, a.compared / 5);
  if (std::string(lambert_batch_isa()) == "avx2") {
    EXPECT_GT(a.scalar_calls, a.compared / 20);  // straddling polygons
    EXPECT_LT(a.scalar_calls, a.compared / 2);   // most take the SIMD path
  }
}

// The same with everything 1e6 away from the origin (relative coordinates keep the digits).
TEST(LambertBatch, AgreesAtA1e6Offset) {
  std::mt19937_64 rng(6);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Vec3 off(1e6, -2e6, 3e6);
  const PolygonBatch batch(random_polygons(rng, 501, off));
  Agreement a;
  for (int i = 0; i < 200; ++i)
    compare({off + Vec3(u(rng), u(rng), u(rng)), random_unit(rng)}, batch, a, "offset " + std::to_string(i));
  a.print("1e6 offset");
  EXPECT_GT(a.nonzero, a.compared / 5);
}

// Small polygons 1e4 to 1e6 sizes away, facing the receiver: F from ~1e-8 down to ~1e-14.
TEST(LambertBatch, AgreesForFarPolygonsWithTinyFormFactors) {
  std::mt19937_64 rng(12);
  std::uniform_real_distribution<double> u(-1.0, 1.0), decade(4.0, 6.0);
  const Vec3 N = Vec3(0.36, 0.48, 0.8);
  std::vector<Polygon> polys;
  for (int i = 0; i < 2001; ++i) {
    Vec3 dir = random_unit(rng);
    if (dir.dot(N) < 0.05) dir = (dir - 2 * dir.dot(N) * N + 0.1 * N).normalized();  // above the horizon
    const double dist = std::pow(10.0, decade(rng));
    Polygon p = random_polygon(rng, dist * dir, 3 + i % 2, 1.0, 0.0, (-dir + 0.5 * random_unit(rng)).normalized());
    if (newell_vector(p).dot(dir) > 0) std::reverse(p.begin(), p.end());  // front towards the receiver
    polys.push_back(p);
  }
  const PolygonBatch batch(polys);
  Agreement a;
  double fmin = 1.0, fmax = 0.0;
  for (int i = 0; i < 20; ++i) {
    const Receiver r{Vec3(u(rng), u(rng), u(rng)), N};
    compare(r, batch, a, "far " + std::to_string(i));
    std::vector<double> out(static_cast<size_t>(batch.size));
    lambert_form_factors(r, batch, out.data());
    for (double f : out)
      if (f > 0) fmin = std::min(fmin, f), fmax = std::max(fmax, f);
  }
  a.print("far polygons");
  std::printf("[ batch    ] far polygons: F in [%.1e, %.1e]\n", fmin, fmax);
  EXPECT_LT(fmin, 1e-12);
  EXPECT_EQ(a.nonzero, a.compared);
  if (std::string(lambert_batch_isa()) == "avx2") { EXPECT_LT(a.scalar_calls, a.compared / 100); }
}

// Receivers exactly in the floor's plane (inside, outside, on edges and vertices, dyadic so that
// they are exactly there), just above it and just below it, with tilted normals: the in-plane
// and boundary cases go to the scalar kernel, the rest agrees to rounding.
TEST(LambertBatch, ReceiversOnAndNearThePolygonPlane) {
  std::vector<Polygon> polys;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {  // the floor [-1, 1]² in 16 quads and 16 triangles
      const double x0 = -1 + 0.5 * i, y0 = -1 + 0.5 * j, x1 = x0 + 0.5, y1 = y0 + 0.5;
      if ((i + j) % 2) polys.push_back({{x0, y0, 0}, {x1, y0, 0}, {x1, y1, 0}, {x0, y1, 0}});
      else
        polys.push_back({{x0, y0, 0}, {x1, y0, 0}, {x1, y1, 0}}),
            polys.push_back({{x0, y0, 0}, {x1, y1, 0}, {x0, y1, 0}});
    }
  polys.push_back({{-1, -1, 0.5}, {-1, 1, 0.5}, {1, 1, 0.5}, {1, -1, 0.5}});  // a ceiling, for SIMD lanes
  const PolygonBatch batch(polys);
  Agreement a;
  const double xs[] = {-1.0, -0.75, -0.5, 0.0, 0.25, 0.3, 1.0, 1.5};
  const double zs[] = {0.0, 1e-15, 1e-12, 1e-9, 1e-6, 1e-3, -1e-12, -1e-6};
  const Vec3 normals[] = {Vec3::UnitZ(), Vec3(0.6, 0, 0.8), Vec3(1, 0, 0), Vec3(0, -0.8, 0.6), Vec3(0, 0, -1)};
  for (double x : xs)
    for (double y : xs)
      for (double z : zs)
        for (const Vec3& n : normals) compare({Vec3(x, y, z), n, Vec3(0.6, 0.8, 0)}, batch, a, "plane");
  a.print("on/near the plane");
  EXPECT_GT(a.scalar_calls, 0);
}

// One call mixing SIMD lanes and scalar-fallback lanes: a closed unit cube of 6·4·4 patches
// (quads and triangles), receivers on its floor (inside patches, on their edges and corners),
// on its walls (their horizon cuts the floor and the ceiling), and just inside. Polygons that
// straddle the receiver's horizon must come from the scalar kernel, bit for bit; every row of
// an interior receiver sums to 1.
TEST(LambertBatch, FallbackLanesMixedWithSimdLanes) {
  const std::vector<Polygon> patches = cube_patches(4);
  const PolygonBatch batch(patches);
  const Vec3 pts[] = {{0.5, 0.5, 0}, {0.3, 0.6, 0}, {0.25, 0.6, 0}, {0.25, 0.25, 0}, {0.0, 0.4, 0}, {0.1, 0.2, 1e-9}};
  std::vector<Receiver> recv;
  for (const Vec3& p : pts) recv.push_back({p, Vec3::UnitZ(), (Vec3(0.5, 0.5, 0) - p).normalized()});
  recv.push_back({{0, 0.3, 0.5}, Vec3::UnitX()});        // on the wall x = 0
  recv.push_back({{0, 0.5, 0.5}, Vec3::UnitX()});        // on a patch corner of that wall
  recv.push_back({{0.4, 1, 0.7}, -Vec3::UnitY()});       // on the wall y = 1
  recv.push_back({{0.5, 0.4, 0.3}, Vec3(0.6, 0, 0.8)});  // inside, tilted
  recv.push_back({{0.2, 0.7, 0.6}, Vec3(-0.48, 0.6, 0.64)});
  recv.push_back({{0.9, 0.1, 0.5}, Vec3(0, -0.6, -0.8)});
  Agreement a;
  int straddling = 0, rows = 0;
  for (const Receiver& r : recv) {
    std::vector<double> out(patches.size());
    const int calls = lambert_form_factors(r, batch, out.data());
    if (std::string(lambert_batch_isa()) == "avx2") {
      EXPECT_GT(calls, 0);
      EXPECT_LT(calls, batch.size);  // some lanes are SIMD
    }
    double sum = 0.0;
    for (size_t k = 0; k < patches.size(); ++k) {
      const double s = lambert_form_factor(r, patches[k]);
      bool below = false, above = false;
      for (const Vec3& v : patches[k]) (r.normal.dot(v - r.point) < 0 ? below : above) = true;
      if (below && above) {
        EXPECT_EQ(out[k], s) << "straddling patch " << k;
        ++straddling;
      }
      EXPECT_TRUE(agrees(out[k], s)) << "patch " << k << ": " << out[k] << " vs " << s;
      sum += out[k];
    }
    compare(r, batch, a, "cube");
    EXPECT_NEAR(sum, 1.0, 1e-13) << r.point.transpose();
    ++rows;
  }
  a.print("closed cube");
  EXPECT_GT(straddling, 20);
  EXPECT_EQ(rows, 12);
}

// Batch sizes 1..37 and every sub-range of the largest: out[k − begin] is the same value
// whatever range the polygon is evaluated in, and nothing outside out[0, end − begin) is written.
TEST(LambertBatch, SubRangesAndSizesThatAreNoMultipleOfTheSimdWidth) {
  std::mt19937_64 rng(37);
  const std::vector<Polygon> polys = random_polygons(rng, 37, Vec3::Zero());
  const Receiver r{Vec3(0.1, -0.2, 0.05), Vec3(0.2, 0.3, 0.9).normalized()};
  for (int n = 0; n <= 37; ++n) {
    const PolygonBatch batch(std::vector<Polygon>(polys.begin(), polys.begin() + n));
    ASSERT_EQ(batch.size, n);
    ASSERT_EQ(batch.padded, (n + 7) / 8 * 8);
    std::vector<double> out(static_cast<size_t>(n) + 2, -7.0);
    lambert_form_factors(r, batch, out.data() + 1);
    EXPECT_EQ(out.front(), -7.0);
    EXPECT_EQ(out.back(), -7.0);
    for (int k = 0; k < n; ++k)
      EXPECT_TRUE(agrees(out[static_cast<size_t>(k) + 1], lambert_form_factor(r, polys[static_cast<size_t>(k)])));
  }
  const PolygonBatch batch(polys);
  std::vector<double> full(37);
  lambert_form_factors(r, batch, full.data());
  for (int begin = 0; begin <= 37; ++begin)
    for (int end = begin; end <= 37; ++end) {
      std::vector<double> out(static_cast<size_t>(end - begin) + 2, -7.0);
      lambert_form_factors(r, batch, begin, end, out.data() + 1);
      ASSERT_EQ(out.front(), -7.0) << begin << ", " << end;
      ASSERT_EQ(out.back(), -7.0) << begin << ", " << end;
      for (int k = begin; k < end; ++k)
        ASSERT_EQ(out[static_cast<size_t>(k - begin) + 1], full[static_cast<size_t>(k)]) << begin << ", " << end;
    }
  double dummy = 0;
  EXPECT_THROW(lambert_form_factors(r, batch, 0, 38, &dummy), std::out_of_range);
  EXPECT_THROW(lambert_form_factors(r, batch, 5, 4, &dummy), std::out_of_range);
  EXPECT_EQ(lambert_form_factors(r, batch, 9, 9, &dummy), 0);
}

// Polygons the SIMD kernel must not touch: the scalar kernel's answer (0, never NaN).
TEST(LambertBatch, DegenerateAndNonFinitePolygonsTakeTheScalarKernel) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Polygon> polys = {
      {{0, 0, 1}, {1, 0, 1}, {2, 0, 1}},                                             // collinear
      {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}},                                  // one point
      {{0, 0, 1}, {1, 0, 1}},                                                        // two vertices
      {},                                                                            // none
      {{0, 0, 1}, {nan, 0, 1}, {1, 1, 1}},                                           // NaN
      {{0, 0, 1e300}, {0, 1e300, 1e300}, {1e300, 1e300, 1e300}, {1e300, 0, 1e300}},  // Newell overflows
      {{0, 1, 1}, {1, 1, 1}, {1, 1, 1}, {1, 0, 1}},  // a repeated vertex: a valid triangle
      {{0, 0, 1}, {0, 1, 1}, {1, 1, 1}, {1, 0, 1}},  // a plain quad
  };
  const PolygonBatch batch(polys);
  EXPECT_EQ(batch.kind[0], 0.0);
  EXPECT_EQ(batch.kind[4], 0.0);
  EXPECT_EQ(batch.kind[5], 0.0);
  EXPECT_EQ(batch.kind[6], 4.0);
  for (const Receiver& r : {Receiver{Vec3::Zero(), Vec3::UnitZ()}, Receiver{Vec3(0.5, 0.5, 0.5), Vec3::UnitZ()},
                            Receiver{Vec3(0.5, 0.5, 1), -Vec3::UnitZ()}, Receiver{Vec3(nan, 0, 0), Vec3::UnitZ()}}) {
    std::vector<double> out(polys.size());
    lambert_form_factors(r, batch, out.data());
    for (size_t k = 0; k < polys.size(); ++k) {
      const double s = lambert_form_factor(r, polys[k]);
      if (std::isnan(s)) EXPECT_TRUE(std::isnan(out[k])) << k;
      else EXPECT_TRUE(agrees(out[k], s)) << k << ": " << out[k] << " vs " << s;
    }
  }
  const Polygon pentagon = {{0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0.5, 1.5, 1}, {0, 1, 1}};
  EXPECT_THROW(PolygonBatch(std::vector<Polygon>{pentagon}), std::invalid_argument);
}

// Receivers whose horizon passes exactly through, or within a few ulps of, a vertex.
TEST(LambertBatch, VerticesOnAndNearTheHorizon) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const std::vector<Polygon> polys = random_polygons(rng, 203, Vec3::Zero());
  const PolygonBatch batch(polys);
  Agreement a;
  for (int i = 0; i < 200; ++i) {
    const Vec3 p(u(rng), u(rng), u(rng));
    const Polygon& target = polys[static_cast<size_t>(i)];
    // A normal perpendicular to p → vertex 0, tilted by 0 or ±1e-15 … 1e-9 rad.
    const Vec3 a0 = (target[0] - p).normalized();
    const Vec3 t = a0.unitOrthogonal();
    const double tilt = i % 5 == 0 ? 0.0 : std::pow(10.0, -15.0 + 6.0 * (i % 7) / 6.0) * (i % 2 ? 1 : -1);
    Vec3 n = (t + tilt * a0).normalized();
    if (newell_vector(target).dot(n) > 0) n = (-t + tilt * a0).normalized();  // face the polygon
    compare({p, n}, batch, a, "horizon " + std::to_string(i));
  }
  a.print("vertex on/near the horizon");
}

// Without AVX2 (forced here) every polygon takes the scalar kernel: the same values, bit for bit.
TEST(LambertBatch, WithoutSimdEveryPolygonTakesTheScalarKernel) {
  std::mt19937_64 rng(99);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const std::vector<Polygon> polys = random_polygons(rng, 45, Vec3::Zero());
  const PolygonBatch batch(polys);
  lambert_batch_detail::set_simd_enabled(false);
  EXPECT_STREQ(lambert_batch_isa(), "scalar");
  double y = 1.0, x = 1.0, t = 0.0;
  EXPECT_FALSE(lambert_batch_detail::simd_atan2(&y, &x, &t, 1));
  for (int i = 0; i < 20; ++i) {
    const Receiver r{Vec3(u(rng), u(rng), u(rng)), random_unit(rng)};
    std::vector<double> out(polys.size());
    EXPECT_EQ(lambert_form_factors(r, batch, 3, 45, out.data()), 42);
    for (size_t k = 3; k < polys.size(); ++k) EXPECT_EQ(out[k - 3], lambert_form_factor(r, polys[k])) << k;
  }
  lambert_batch_detail::set_simd_enabled(true);
}

// A large polygon seen at grazing incidence from close by: its edge terms are O(1) and cancel to
// a small F, so the SIMD lanes hand it to the scalar kernel (bit-identical result), while the
// same polygon seen from further up stays on the SIMD path.
TEST(LambertBatch, StronglyCancellingTermsTakeTheScalarKernel) {
  const Polygon floor = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};  // front +z
  const PolygonBatch batch(std::vector<Polygon>{floor});
  const Vec3 n = Vec3(0.01, 0, 1).normalized();  // every vertex above the horizon
  for (double h : {1e-6, 1e-4}) {
    const Receiver r{Vec3(-0.5, 0.5, h), n};
    double f = -1.0;
    const int calls = lambert_form_factors(r, batch, &f);
    const double s = lambert_form_factor(r, floor);
    ASSERT_GT(s, 0.0);
    ASSERT_LT(s, 1e-3);
    EXPECT_EQ(f, s) << h;
    if (std::string(lambert_batch_isa()) == "avx2") { EXPECT_EQ(calls, 1) << h; }
  }
  double f = -1.0;
  const Receiver high{Vec3(-0.5, 0.5, 0.5), n};
  const int calls = lambert_form_factors(high, batch, &f);
  EXPECT_TRUE(agrees(f, lambert_form_factor(high, floor)));
  if (std::string(lambert_batch_isa()) == "avx2") { EXPECT_EQ(calls, 0); }
}

// A receiver at a vertex of its own wall's grid (the per-vertex gather): the coplanar patches
// around it and across the wall give 0 without a scalar call, exactly as the scalar kernel does,
// also with an approach direction in the wall's plane; a tilted patch still goes to the kernel.
TEST(LambertBatch, PolygonsInTheReceiverPlaneGiveZeroWithoutTheScalarKernel) {
  std::vector<Polygon> grid;
  for (int u = 0; u < 4; ++u)
    for (int w = 0; w < 4; ++w) {
      const double x = 0.25 * u, y = 0.25 * w;
      grid.push_back({Vec3(x, y, 0), Vec3(x + 0.25, y, 0), Vec3(x + 0.25, y + 0.25, 0), Vec3(x, y + 0.25, 0)});
    }
  const PolygonBatch batch(grid);
  for (const Vec3& p : {Vec3(0.5, 0.5, 0), Vec3(0.25, 0.0, 0), Vec3(0.3, 0.7, 0)}) {
    for (const Vec3& approach : {Vec3(0, 0, 0), Vec3(std::sqrt(0.5), std::sqrt(0.5), 0)}) {
      const Receiver r{p, Vec3::UnitZ(), approach};
      std::vector<double> out(grid.size(), -1.0);
      EXPECT_EQ(lambert_form_factors(r, batch, out.data()), 0);
      for (size_t k = 0; k < grid.size(); ++k) {
        EXPECT_EQ(out[k], 0.0);
        EXPECT_EQ(lambert_form_factor(r, grid[k]), 0.0);
      }
    }
  }
  // Not exactly in the plane: the kernel decides.
  const PolygonBatch tilted(std::vector<Polygon>{{Vec3(0, 0, 0), Vec3(1, 0, 1e-3), Vec3(1, 1, 1e-3), Vec3(0, 1, 0)}});
  double f = -1.0;
  lambert_form_factors(Receiver{Vec3(0.5, -0.5, 0), Vec3::UnitZ()}, tilted, &f);
  EXPECT_EQ(f, lambert_form_factor(Receiver{Vec3(0.5, -0.5, 0), Vec3::UnitZ()},
                                   Polygon{Vec3(0, 0, 0), Vec3(1, 0, 1e-3), Vec3(1, 1, 1e-3), Vec3(0, 1, 0)}));
}

// Shared edges (PolygonBatch::share_edges): each polygon's value is its own edge sum's bit for
// bit (also where the receiver is exactly as far from an edge's two ends, and the polygon that
// runs it backwards builds its cross product on the other end) and so within the scalar
// kernel's agreement. Meshed cube walls (quads and triangles) over several chunks, a degenerate
// and a non-finite polygon among them, whole chunks and sub-ranges (which sum their own edges).
TEST(LambertBatch, SharedEdgesGiveEachPolygonItsOwnSum) {
  std::vector<Polygon> patches = cube_patches(20);  // 6 × 20 × 20 cells, half of them two triangles
  const double nan = std::numeric_limits<double>::quiet_NaN();
  patches.insert(patches.begin() + 300, Polygon{{0.1, 0.1, 0.0}, {0.2, 0.1, 0.0}, {0.3, 0.1, 0.0}});  // no area
  patches.insert(patches.begin() + 700, Polygon{{0.1, 0.1, 0.0}, {nan, 0.1, 0.0}, {0.3, 0.2, 0.0}});
  const PolygonBatch own(patches);
  PolygonBatch shared(patches);
  shared.share_edges();
  ASSERT_TRUE(shared.edges_shared());
  ASSERT_FALSE(own.edges_shared());
  const int chunks = (shared.padded + PolygonBatch::kEdgeChunk - 1) / PolygonBatch::kEdgeChunk;
  ASSERT_EQ(shared.chunk_edges.size(), size_t(chunks) + 1);
  EXPECT_GT(chunks, 10);
  // A grid of cells shares most edges: fewer than 3 per polygon rather than 4 (a triangle's
  // repeated corner adds a zero-length edge).
  EXPECT_LT(shared.chunk_edges.back(), 3 * shared.size);
  std::vector<Receiver> recv;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0.05, 0.95);
  for (int i = 0; i < 12; ++i) recv.push_back({Vec3(u(rng), u(rng), u(rng)), random_unit(rng)});
  recv.push_back({{0.5, 0.5, 0.0}, Vec3::UnitZ()});    // on the floor, at corners of cells: ties
  recv.push_back({{0.525, 0.5, 0.0}, Vec3::UnitZ()});  // on the floor, on an edge
  recv.push_back({{0.0, 0.5, 0.5}, Vec3::UnitX(), Vec3(0, 0, 1)});
  recv.push_back({{0.3, 0.3, 0.5}, Vec3::UnitX()});
  long values = 0;
  for (const Receiver& r : recv) {
    std::vector<double> want(size_t(own.size)), got(size_t(shared.size), -1.0);
    lambert_form_factors(r, own, want.data());
    lambert_form_factors(r, shared, got.data());
    Vec3 v[4];
    for (int k = 0; k < own.size; ++k) {
      const double s = lambert_form_factor(r, v, shared.vertices(k, v));
      if (std::isnan(s)) {  // the non-finite polygon: the scalar kernel's NaN, as without shared edges
        EXPECT_TRUE(std::isnan(got[size_t(k)]) && std::isnan(want[size_t(k)])) << k;
        continue;
      }
      EXPECT_TRUE(agrees(got[size_t(k)], s)) << "polygon " << k << ": " << got[size_t(k)] << " vs " << s;
      ASSERT_EQ(got[size_t(k)], want[size_t(k)]) << "polygon " << k << " from " << r.point.transpose();
      ++values;
    }
    // A sub-range that is no whole chunk: its polygons sum their own edges.
    std::vector<double> part(300);
    lambert_form_factors(r, shared, 1000, 1300, part.data());
    for (int k = 1000; k < 1300; ++k) EXPECT_EQ(part[size_t(k - 1000)], want[size_t(k)]) << k;
  }
  EXPECT_GT(values, 50000);
  // A polygon pushed afterwards makes the tables stale: they are forgotten.
  shared.push_back(patches.front());
  EXPECT_FALSE(shared.edges_shared());
}
