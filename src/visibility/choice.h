// The visibility decision of a run, made once for the solve and for `viewfactors` alike: which
// method computes what blocks light (none, rays or exact clipping), and why.
//
// Auto: none for a scene where nothing can block (visibility.h scene_needs_no_visibility: a
// convex enclosure); otherwise the cheaper of exact clipping and rays by an estimate of their
// cost per receiver point and occluded source (estimate_visibility_cost), from the occluders that
// can shadow a point of a sample of the scene's faces (its centroid) from another face: clipping
// costs more the more occluders a point's shaft holds (each cuts the visible fragments the next
// must clip), rays cost their count.
#pragma once

#include <cstddef>
#include <memory>
#include <string>

#include "scene/scene.h"
#include "visibility/visibility.h"

namespace photometria {

enum class VisibilityMode { Auto, None, Rays, Exact };

// The cost model of `auto`, in seconds of one core per receiver point and occluded source:
//   exact ≈ kClipSecondsPerOccluder × m (1 + m / 4),   rays ≈ kSecondsPerRay × rays
// with m the mean count of occluders that can shadow the receiver face's centroid from the source
// face (ShaftCuller::occluders of the point's shaft, less the back occluders of closed solids the
// point is outside of: what the fill and the gather clip), over the sampled face pairs that have
// any. Measured on the project's 2-core VM (docs/theory.md "How auto chooses"): 1.7 µs per
// exactly clipped point on the 1,666-face room, where m = 1.78, and 0.26 µs per single ray on
// the same room. Packets of 8 (RayVisibility::blocked_from) halved the time per ray on the
// Cornell box (0.155 -> 0.076 core-µs), but the model keeps 0.26: with 0.13 it picked rays for
// the bench room at 0.5 m (446 patches), which then took 6.5 s against 0.49 s with clipping (the
// rays' per-point costs and their count on partly hidden pairs are not in the model).
inline constexpr double kClipSecondsPerOccluder = 0.66e-6;
inline constexpr double kSecondsPerRay = 0.26e-6;
inline constexpr int kDefaultRays = kAdaptiveRays;  // rays per (receiver point, source patch) unless asked otherwise
// The mean count adaptive sampling (visibility.h, RaySampling: 8² to 32² at 1e-2) casts per
// (point, patch) in an occluded shaft, for the cost model: 306 on the Cornell box solved with
// --visibility rays (239.7 M rays where a fixed 576 cast 451.1 M; docs/performance.md).
inline constexpr double kAdaptiveRaysExpected = 306;

struct VisibilityCostEstimate {
  int sampled_pairs = 0;        // facing face pairs whose shafts were culled
  int occluded_pairs = 0;       // of those, with a candidate occluder in the shaft
  double mean_occluders = 0.0;  // m: occluders per point's shaft, over the occluded pairs
  double exact_seconds = 0.0;   // per receiver point and occluded source, one core
  double rays_seconds = 0.0;
};

// Samples up to `samples` pairs of facing scene faces (deterministic: a fixed stride through the
// pairs) of the culler's scene and culls the shaft from the first face's centroid to the second.
// `rays`: the ray count the run would use (kAdaptiveRays: kAdaptiveRaysExpected).
VisibilityCostEstimate estimate_visibility_cost(const ShaftCuller& culler, int rays, int samples = 512);

// "auto", "none", "rays", "exact" -> the mode; throws Error(BadInput) naming --visibility and
// the choices for anything else.
VisibilityMode parse_visibility_mode(const std::string& text);

struct VisibilityChoice {
  VisibilityMode mode = VisibilityMode::None;  // resolved: None, Rays or Exact (never Auto)
  std::string reason;                          // "requested (--visibility rays)" or "auto: <why>", for the summary
  std::string name() const;                    // "none", "rays" or "exact"
};

// The mode `requested` resolves to for `scene` (Auto decided as above, for `rays` rays per point).
VisibilityChoice choose_visibility(const Scene& scene, VisibilityMode requested, int rays = kDefaultRays);

// `--rays`: "auto" -> kAdaptiveRays, an integer in [1, 2²⁴] -> that count; throws
// Error(BadInput) naming --rays and the value for anything else.
int parse_ray_count(const std::string& text);

// What a run's ray sampling is, for the summaries: "adaptive, 8² to 32² rays per point and patch,
// to a relative error of 1e-07" or "576 rays per point and patch".
std::string ray_sampling_name(int rays, const RaySampling& sampling);

// Ray mode's adaptive sampling for a run asked to `accuracy` (relative; 0 = not asked: 1e-2).
inline RaySampling ray_sampling_for(double accuracy) {
  RaySampling s;
  if (accuracy > 0.0) s.tolerance = accuracy;
  return s;
}

// The visibility object of a choice: null for None. sampling: ray mode's adaptive sampling.
std::unique_ptr<Visibility> make_visibility(const Scene& scene, const VisibilityChoice& choice,
                                            RaySampling sampling = {});

}  // namespace photometria
