#include "visibility/choice.h"

#include <algorithm>
#include <charconv>
#include <sstream>
#include <vector>

#include "util/error.h"

namespace photometria {

VisibilityMode parse_visibility_mode(const std::string& text) {
  if (text == "auto") return VisibilityMode::Auto;
  if (text == "none") return VisibilityMode::None;
  if (text == "rays") return VisibilityMode::Rays;
  if (text == "exact") return VisibilityMode::Exact;
  throw_bad_input("--visibility: '" + text + "' is not one of auto, none, rays, exact");
}

std::string VisibilityChoice::name() const {
  switch (mode) {
    case VisibilityMode::Rays: return "rays";
    case VisibilityMode::Exact: return "exact";
    default: return "none";
  }
}

int parse_ray_count(const std::string& text) {
  if (text == "auto") return kAdaptiveRays;
  long long v = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, v);
  if (text.empty() || ec != std::errc() || ptr != end || v < 1 || v > (1 << 24))
    throw_bad_input("--rays: " + text + " is not auto or an integer in [1, 16777216]");
  return static_cast<int>(v);
}

std::string ray_sampling_name(int rays, const RaySampling& sampling) {
  std::ostringstream o;
  if (rays != kAdaptiveRays) {
    o << rays << " rays per point and patch";
    return o.str();
  }
  int last = 8;
  while (4 * last * last <= sampling.max_rays) last *= 2;
  o << "adaptive, 8² to " << last << "² rays per point and patch, to a relative error of " << sampling.tolerance;
  return o.str();
}

VisibilityCostEstimate estimate_visibility_cost(const ShaftCuller& culler, int rays, int samples) {
  VisibilityCostEstimate e;
  const std::vector<Polygon>& faces = culler.scene_faces();
  const long long n = static_cast<long long>(faces.size());
  std::vector<Vec3> normals(faces.size());
  for (size_t f = 0; f < faces.size(); ++f) normals[f] = polygon_normal(faces[f]);
  // True when some corner of b lies in front of a's plane.
  const auto in_front = [&](size_t a, size_t b) {
    for (const Vec3& v : faces[b])
      if (normals[a].dot(v - faces[a][0]) > culler.tolerance()) return true;
    return false;
  };
  std::vector<int> found;
  long long occluders = 0;
  // Pairs (a, b), a != b, visited with a stride coprime to n² so that the sample spreads over the scene.
  const long long pairs = n * n;
  const long long stride = pairs > 1 ? std::max(1LL, pairs / std::max(1, samples)) | 1 : 1;
  for (long long k = 0, tried = 0; tried < std::min(pairs, 8LL * samples) && e.sampled_pairs < samples; ++tried) {
    k = (k + stride) % std::max(1LL, pairs);
    const size_t a = size_t(k / n), b = size_t(k % n);
    if (a == b || faces[b].size() + 1 > 24 || !in_front(a, b) || !in_front(b, a)) continue;
    ++e.sampled_pairs;
    // From a receiver point (the face's centroid, inside it), as the fill and the gather cull:
    // the point's shaft, without the back occluders of closed solids it is outside of.
    const Vec3 x = polygon_centroid(faces[a]);
    culler.occluders(&x, 1, faces[b].data(), int(faces[b].size()), found, /*drop_hidden=*/true, int(a));
    if (found.empty()) continue;
    ++e.occluded_pairs;
    occluders += static_cast<long long>(found.size());
  }
  if (e.occluded_pairs > 0) e.mean_occluders = double(occluders) / e.occluded_pairs;
  const double m = e.mean_occluders;
  e.exact_seconds = kClipSecondsPerOccluder * m * (1.0 + m / 4.0);
  e.rays_seconds = kSecondsPerRay * (rays == kAdaptiveRays ? kAdaptiveRaysExpected : rays);
  return e;
}

VisibilityChoice choose_visibility(const Scene& scene, VisibilityMode requested, int rays) {
  VisibilityChoice c;
  c.mode = requested;
  switch (requested) {
    case VisibilityMode::None: c.reason = "requested (--visibility none)"; return c;
    case VisibilityMode::Rays: c.reason = "requested (--visibility rays)"; return c;
    case VisibilityMode::Exact: c.reason = "requested (--visibility exact)"; return c;
    case VisibilityMode::Auto: break;
  }
  std::string why;
  if (scene_needs_no_visibility(scene, &why)) {
    c.mode = VisibilityMode::None;
    c.reason = "auto: " + why;
    return c;
  }
  const ShaftCuller culler(scene);
  const VisibilityCostEstimate e = estimate_visibility_cost(culler, rays);
  const bool exact = e.exact_seconds <= e.rays_seconds;
  c.mode = exact ? VisibilityMode::Exact : VisibilityMode::Rays;
  std::ostringstream o;
  o.precision(2);
  o << "auto: " << why << "; " << e.mean_occluders << " occluders per occluded point shaft (" << e.occluded_pairs
    << " of " << e.sampled_pairs << " sampled face pairs), so clipping costs about " << e.exact_seconds * 1e6
    << " us per point against " << e.rays_seconds * 1e6 << " us for "
    << (rays == kAdaptiveRays ? "adaptive" : std::to_string(rays)) << " rays: " << (exact ? "exact clipping" : "rays");
  c.reason = o.str();
  return c;
}

std::unique_ptr<Visibility> make_visibility(const Scene& scene, const VisibilityChoice& choice, RaySampling sampling) {
  if (choice.mode == VisibilityMode::None) return nullptr;
  return std::make_unique<Visibility>(
      scene, choice.mode == VisibilityMode::Exact ? VisibilityMethod::Exact : VisibilityMethod::Rays, sampling);
}

}  // namespace photometria
