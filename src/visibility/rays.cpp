// Ray-cast visibility with Embree 3 (visibility.h, 2.): V(x, P) as the integrand-weighted
// fraction of unblocked segments between stratified points, and the per-pair sampling streams.
#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "util/error.h"
#include "visibility/visibility.h"
#include "visibility/visibility_internal.h"

namespace photometria {

using visibility_detail::bounding_diagonal;

namespace {

// splitmix64 (Steele, Lea & Flood 2014): a tiny, well-mixed generator for per-pair streams.
struct SplitMix64 {
  uint64_t state;
  uint64_t next() {
    uint64_t z = (state += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  double uniform() { return double(next() >> 11) * 0x1.0p-53; }
};

// Latin-hypercube samples in the unit square: one sample in each of K columns and K rows.
void latin_hypercube(int k, SplitMix64& rng, std::vector<std::pair<double, double>>& out) {
  std::vector<int> perm(k);
  for (int i = 0; i < k; ++i) perm[i] = i;
  for (int i = k - 1; i > 0; --i) std::swap(perm[i], perm[rng.next() % uint64_t(i + 1)]);
  out.resize(k);
  for (int i = 0; i < k; ++i) out[i] = {(i + rng.uniform()) / k, (perm[i] + rng.uniform()) / k};
}

// Jittered (stratified) samples: one in each cell of an m × m grid, k = m². An indicator with a
// smooth boundary then has error O(k^(-3/4)) instead of O(k^(-1/2)) (Mitchell 1996, "Consequences
// of stratified sampling in graphics").
void jittered_grid(int m, SplitMix64& rng, std::vector<std::pair<double, double>>& out) {
  out.resize(size_t(m) * m);
  for (int a = 0; a < m; ++a)
    for (int b = 0; b < m; ++b) out[size_t(a) * m + b] = {(a + rng.uniform()) / m, (b + rng.uniform()) / m};
}

// Uniform (area-preserving for triangles and parallelograms) map of the unit square to a patch.
Vec3 map_to_patch(const Vec3* c, int n, double s, double t) {
  if (n == 4) return (1 - s) * (1 - t) * c[0] + s * (1 - t) * c[1] + s * t * c[2] + (1 - s) * t * c[3];
  const double r = std::sqrt(s);  // Shirley's square-to-triangle map
  return (1 - r) * c[0] + r * (1 - t) * c[1] + r * t * c[2];
}

// The form-factor integrand between two surface points, cos θx cos θy / r²: each segment's
// visibility counts in proportion to the light it carries, so that V·F estimates the occluded
// factor ∫∫ v cos cos / (π r²) rather than an area-average that ignores where F comes from.
double transfer_weight(const Vec3& x, const Vec3& nx, const Vec3& y, const Vec3& ny) {
  const Vec3 d = y - x;
  const double r2 = d.squaredNorm();
  if (r2 == 0.0) return 0.0;
  const double cx = nx.dot(d), cy = -ny.dot(d);
  if (cx <= 0.0 || cy <= 0.0) return 0.0;
  return cx * cy / (r2 * r2);
}

}  // namespace

uint64_t pair_stream(uint64_t seed, uint64_t i, uint64_t j) {
  SplitMix64 g{seed ^ (i * 0x9e3779b97f4a7c15ULL) ^ (j * 0xc2b2ae3d27d4eb4fULL)};
  return g.next();
}

struct RayVisibility::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
};

RayVisibility::RayVisibility(const Scene& scene, RaySampling sampling)
    : impl_(std::make_unique<Impl>()), sampling_(sampling) {
  offset_ = 1e-7 * std::max(bounding_diagonal(scene.vertices), 1e-30);
  impl_->device = rtcNewDevice("verbose=0");
  if (!impl_->device) throw Error(ErrorKind::Io, "embree: cannot create a device");
  impl_->scene = rtcNewScene(impl_->device);
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);
  // Watertight triangle tests: a segment through an edge shared by two faces cannot slip through.
  rtcSetSceneFlags(impl_->scene, RTC_SCENE_FLAG_ROBUST);
  RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                         3 * sizeof(float), scene.vertices.size()));
  for (size_t i = 0; i < scene.vertices.size(); ++i)
    for (int k = 0; k < 3; ++k) vb[3 * i + k] = static_cast<float>(scene.vertices[i][k]);
  size_t tris = 0;
  for (const Face& f : scene.faces) tris += f.vertices.size() - 2;
  auto* ib = static_cast<unsigned*>(
      rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), tris));
  size_t t = 0;
  for (const Face& f : scene.faces)
    for (size_t k = 1; k + 1 < f.vertices.size(); ++k, ++t) {
      ib[3 * t] = f.vertices[0];
      ib[3 * t + 1] = f.vertices[k];
      ib[3 * t + 2] = f.vertices[k + 1];
    }
  rtcCommitGeometry(geom);
  rtcAttachGeometry(impl_->scene, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(impl_->scene);
  if (rtcGetDeviceError(impl_->device) != RTC_ERROR_NONE)
    throw Error(ErrorKind::Io, "embree: failed to build the occluder scene");
}

RayVisibility::~RayVisibility() {
  if (impl_->scene) rtcReleaseScene(impl_->scene);
  if (impl_->device) rtcReleaseDevice(impl_->device);
}

bool RayVisibility::blocked(const Vec3& a, const Vec3& b) const {
  const Vec3 d = b - a;
  const double len = d.norm();
  if (len <= 2 * offset_) return false;
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay ray;
  ray.org_x = float(a.x());
  ray.org_y = float(a.y());
  ray.org_z = float(a.z());
  ray.dir_x = float(d.x() / len);
  ray.dir_y = float(d.y() / len);
  ray.dir_z = float(d.z() / len);
  // Leave the end points' own surfaces alone: float storage of the occluders costs ~1e-7 relative.
  ray.tnear = float(offset_);
  ray.tfar = float(len - offset_);
  ray.time = 0.0f;
  ray.mask = 0xFFFFFFFFu;
  ray.id = 0;
  ray.flags = 0;
  rtcOccluded1(impl_->scene, &context, &ray);
  return ray.tfar < 0.0f;  // Embree sets tfar = -inf on a hit
}

void RayVisibility::blocked_from(const Vec3& a, const Vec3* b, int count, bool* out) const {
  RTCRay8 rays;
  alignas(32) int valid[8];
  for (int k = 0; k < 8; ++k) {
    const Vec3 d = k < count ? Vec3(b[k] - a) : Vec3::UnitZ();
    const double len = d.norm();
    // As blocked(): segments shorter than twice the offset are never blocked.
    valid[k] = k < count && len > 2 * offset_ ? -1 : 0;
    out[k] = false;
    rays.org_x[k] = float(a.x());
    rays.org_y[k] = float(a.y());
    rays.org_z[k] = float(a.z());
    rays.dir_x[k] = float(d.x() / len);
    rays.dir_y[k] = float(d.y() / len);
    rays.dir_z[k] = float(d.z() / len);
    rays.tnear[k] = float(offset_);
    rays.tfar[k] = valid[k] ? float(len - offset_) : 0.0f;
    rays.time[k] = 0.0f;
    rays.mask[k] = 0xFFFFFFFFu;
    rays.id[k] = unsigned(k);
    rays.flags[k] = 0;
  }
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  rtcOccluded8(valid, impl_->scene, &context, &rays);
  for (int k = 0; k < count; ++k) out[k] = valid[k] && rays.tfar[k] < 0.0f;  // tfar = -inf on a hit
}

double RayVisibility::patch_to_patch(const Vec3* r, int rn, const Vec3& r_normal, const Vec3* s, int sn,
                                     const Vec3& s_normal, int rays, uint64_t stream) const {
  SplitMix64 rng{stream};
  std::vector<std::pair<double, double>> a, b;
  latin_hypercube(rays, rng, a);
  latin_hypercube(rays, rng, b);
  double seen = 0.0, total = 0.0;
  for (int k = 0; k < rays; ++k) {
    const Vec3 x = map_to_patch(r, rn, a[k].first, a[k].second);
    const Vec3 y = map_to_patch(s, sn, b[k].first, b[k].second);
    const double w = transfer_weight(x, r_normal, y, s_normal);
    if (w == 0.0) continue;
    total += w;
    // Lift the end points off their surfaces towards their front sides.
    if (!blocked(x + 10 * offset_ * r_normal, y + 10 * offset_ * s_normal)) seen += w;
  }
  return total > 0 ? seen / total : 1.0;
}

double RayVisibility::point_to_patch(const Vec3& p, const Vec3& normal, const Vec3* s, int sn, const Vec3& s_normal,
                                     int rays, uint64_t stream, int* rays_used, double* variance) const {
  SplitMix64 rng{stream};
  std::vector<std::pair<double, double>> b;
  const Vec3 x = p + 10 * offset_ * normal;
  int used = 0;
  // One stratified estimate of V from k segments, with its estimated variance: that of a ratio
  // estimator Σ w v / Σ w (Cochran, "Sampling Techniques", 3rd ed., Wiley 1977, ch. 6; visibility.h).
  struct Estimate {
    double visible = 1.0, variance = 0.0;
    bool unanimous = true;
  };
  std::vector<double> w, v;
  std::vector<Vec3> ends;
  auto estimate = [&](int k) {
    const int m = static_cast<int>(std::lround(std::sqrt(double(k))));
    if (m * m == k) jittered_grid(m, rng, b);
    else latin_hypercube(k, rng, b);
    w.clear();
    v.clear();
    ends.clear();
    double seen = 0.0, total = 0.0;
    for (int q = 0; q < k; ++q) {
      const Vec3 y = map_to_patch(s, sn, b[q].first, b[q].second);
      const double wq = transfer_weight(p, normal, y, s_normal);
      if (wq == 0.0) continue;
      total += wq;
      w.push_back(wq);
      ends.push_back(y + 10 * offset_ * s_normal);
    }
    used += static_cast<int>(ends.size());
    // The segments in packets of 8, in sample order.
    for (size_t first = 0; first < ends.size(); first += 8) {
      bool hit[8];
      const int count = static_cast<int>(std::min<size_t>(8, ends.size() - first));
      blocked_from(x, ends.data() + first, count, hit);
      for (int q = 0; q < count; ++q) {
        const double clear = hit[q] ? 0.0 : 1.0;
        seen += w[first + size_t(q)] * clear;
        v.push_back(clear);
      }
    }
    Estimate e;
    if (!(total > 0.0)) return e;
    e.visible = seen / total;
    double sum = 0.0;
    for (size_t q = 0; q < w.size(); ++q) {
      sum += w[q] * w[q] * (v[q] - e.visible) * (v[q] - e.visible);
      e.unanimous = e.unanimous && v[q] == v[0];
    }
    e.variance = sum / (total * total);
    return e;
  };
  Estimate e;
  if (rays != kAdaptiveRays) {
    e = estimate(rays);
  } else {
    // Levels of 8², 16², 32², ...: each a fresh estimate (the last one is kept), so the cost is at
    // most 4/3 of the last level's.
    for (int m = 8;; m *= 2) {
      e = estimate(m * m);
      const bool settled =
          e.unanimous || std::sqrt(e.variance) <= sampling_.tolerance * std::max(e.visible, kRayErrorFloor);
      if (settled || 4 * m * m > sampling_.max_rays) break;
    }
  }
  if (rays_used) *rays_used = used;
  if (variance) *variance = e.variance;
  return e.visible;
}

}  // namespace photometria
