// Ray-cast visibility against the analytic occluded configurations: convergence with the number
// of rays, and the error at the default setting.
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
  long long cast = 0;
  for (int s = 0; s < seeds; ++s) {
    const double f = vis.point_to_patch(x, c.source.data(), 4, ns, f0, occ, rays, pair_stream(s, 0, 1), cast);
    EXPECT_LE(f, f0);
    sum2 += std::pow((f - c.reference) / c.reference, 2);
  }
  EXPECT_GE(cast, (long long)rays * seeds);
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
