// Ray-cast visibility against the analytic occluded configurations: convergence with the number
// of rays, the error at the default setting, and adaptive sampling's count and error estimate.
#include <gtest/gtest.h>

#include <cstdio>

#include "kernels/lambert.h"
#include "pipeline/solve.h"
#include "visibility/visibility.h"
#include "visibility_configs.h"

using namespace photometria;
using namespace vis_configs;

namespace {

struct Config {
  Polygon source;
  std::vector<Polygon> blockers;
  double reference;
};

// An off-centre blocker halfway: shadow [0.26, 1.22] × [-0.46, 0.58] on the source, cut by its
// edge x = 1. The shadow's edges are chosen off every stratum boundary of the grids used here, so
// that stratification gets no lucky exact answer.
Config off_centre() {
  return {rect_poly(-1, 1, -1, 1, 2),
          {rect_poly(0.13, 0.61, -0.23, 0.29, 1)},
          rect(-1, 1, -1, 1, 2) - rect(0.26, 1, -0.46, 0.58, 2)};
}

// RMS relative error of the ray estimate over `seeds` seeds.
double rms_error(const Config& c, int rays, int seeds) {
  std::vector<Polygon> faces = c.blockers;
  faces.push_back(c.source);
  const Visibility vis(scene_of(faces), VisibilityMethod::Rays);
  const Receiver x{Vec3::Zero(), Vec3::UnitZ()};
  std::vector<int> occ;
  vis.culler().occluders(&x.point, 1, c.source.data(), 4, occ);
  EXPECT_FALSE(occ.empty());
  const double f0 = lambert_form_factor(x, c.source);
  const Vec3 ns = polygon_normal(c.source);
  double sum2 = 0.0;
  RayTally cast;
  for (int s = 0; s < seeds; ++s) {
    const double f = vis.point_to_patch(x, c.source.data(), 4, ns, f0, occ, rays, pair_stream(s, 0, 1), cast);
    EXPECT_LE(f, f0);
    sum2 += std::pow((f - c.reference) / c.reference, 2);
  }
  EXPECT_GE(cast.cast, (long long)(rays == kAdaptiveRays ? 64 : rays) * seeds);  // adaptive: at least 8² each
  return std::sqrt(sum2 / seeds);
}

}  // namespace

TEST(VisibilityRays, ConvergesAtLeastAsOneOverSqrtRays) {
  const Config c = off_centre();
  std::vector<int> ks = {16, 64, 256, 1024, 4096};
  std::vector<double> errors;
  for (int k : ks) {
    errors.push_back(rms_error(c, k, 64));
    std::printf("rays %5d  rms relative error %.3e\n", k, errors.back());
  }
  for (size_t i = 1; i < ks.size(); ++i) EXPECT_LT(errors[i], errors[i - 1]);
  // 1/sqrt(rays) would divide the error by 16 from 16 to 4096 rays; allow 1.5× for the noise of
  // the estimate of the error itself.
  EXPECT_LT(errors.back(), 1.5 * errors.front() / 16.0);
}

TEST(VisibilityRays, DefaultRaysReachOnePercent) {
  const int rays = SolveOptions{}.rays;
  const double e = rms_error(off_centre(), rays, 64);
  std::printf("default %d rays: rms relative error %.3e\n", rays, e);
  EXPECT_LT(e, 0.01);
}

namespace {

// Adaptive sampling of `c` from the origin with `sampling`, over `seeds` seeds: the RMS of the
// actual relative errors, the RMS of the estimated ones (√variance / reference) and the mean count.
struct AdaptiveRun {
  double actual = 0.0, estimated = 0.0, mean_rays = 0.0;
};
AdaptiveRun adaptive_run(const Config& c, RaySampling sampling, int seeds) {
  std::vector<Polygon> faces = c.blockers;
  faces.push_back(c.source);
  const RayVisibility rays(scene_of(faces), sampling);
  const Vec3 ns = polygon_normal(c.source);
  const double f0 = lambert_form_factor(Receiver{Vec3::Zero(), Vec3::UnitZ()}, c.source);
  AdaptiveRun r;
  for (int s = 0; s < seeds; ++s) {
    int used = 0;
    double variance = 0.0;
    const double v = rays.point_to_patch(Vec3::Zero(), Vec3::UnitZ(), c.source.data(), 4, ns, kAdaptiveRays,
                                         pair_stream(s, 3, 5), &used, &variance);
    r.actual += std::pow((v * f0 - c.reference) / c.reference, 2);
    r.estimated += variance * f0 * f0 / (c.reference * c.reference);
    r.mean_rays += used;
  }
  r.actual = std::sqrt(r.actual / seeds);
  r.estimated = std::sqrt(r.estimated / seeds);
  r.mean_rays /= seeds;
  return r;
}

}  // namespace

// A partly hidden source: the count grows with the accuracy asked (8², 16², 32², 64² levels), the
// error falls, and the estimate bounds the actual error without overstating it tenfold (it is that
// of independent samples; jittered ones err less).
TEST(VisibilityRays, AdaptiveCountFollowsTheAccuracyAndEstimatesItsError) {
  const Config c = off_centre();
  const AdaptiveRun loose = adaptive_run(c, {1e-1, 4096}, 64), tight = adaptive_run(c, {1e-4, 4096}, 64);
  std::printf("tolerance 1e-1: %.0f rays, rms error %.3e, estimated %.3e\n", loose.mean_rays, loose.actual,
              loose.estimated);
  std::printf("tolerance 1e-4: %.0f rays, rms error %.3e, estimated %.3e\n", tight.mean_rays, tight.actual,
              tight.estimated);
  EXPECT_LE(loose.mean_rays, 256);                     // settled by 16² at the latest
  EXPECT_EQ(tight.mean_rays, 64 + 256 + 1024 + 4096);  // 1e-4 is out of reach: every level up to the cap
  EXPECT_LT(tight.actual, loose.actual / 4);
  for (const AdaptiveRun& r : {loose, tight}) {
    EXPECT_GE(r.estimated, 0.8 * r.actual);
    EXPECT_LE(r.estimated, 10 * r.actual);
  }
}

// A source nothing hides, and one hidden whole: the first level agrees everywhere, so 8² rays
// settle it, with no error estimated.
TEST(VisibilityRays, AdaptiveStopsAtTheFirstLevelWhenEveryRayAgrees) {
  const Polygon source = rect_poly(-1, 1, -1, 1, 2);
  const Vec3 ns = polygon_normal(source);
  for (const bool hidden : {false, true}) {
    // Hidden: a blocker wider than the source's whole cone, halfway. Clear: a blocker off to the side.
    const Polygon blocker = hidden ? rect_poly(-2, 2, -2, 2, 1) : rect_poly(5, 6, 5, 6, 1);
    const RayVisibility rays(scene_of({blocker, source}));
    int used = 0;
    double variance = -1.0;
    const double v =
        rays.point_to_patch(Vec3::Zero(), Vec3::UnitZ(), source.data(), 4, ns, kAdaptiveRays, 9, &used, &variance);
    EXPECT_EQ(v, hidden ? 0.0 : 1.0);
    EXPECT_EQ(used, 64);
    EXPECT_EQ(variance, 0.0);
  }
}
