// The visibility decision of a run, made once for the solve and for `viewfactors` alike: which
// method computes what blocks light (none, rays or exact clipping), and why.
//
// Auto: none for a scene where nothing can block (visibility.h scene_needs_no_visibility: a
// convex enclosure); exact for scenes of at most kAutoExactMaxFaces faces (few occluders per
// shaft: clipping is exact and, on the shipped rooms, faster than rays at the default ray
// count; docs/performance.md); rays beyond.
#pragma once

#include <cstddef>
#include <memory>
#include <string>

#include "scene/scene.h"
#include "visibility/visibility.h"

namespace photometria {

enum class VisibilityMode { Auto, None, Rays, Exact };
inline constexpr size_t kAutoExactMaxFaces = 256;

// "auto", "none", "rays", "exact" -> the mode; throws Error(BadInput) naming --visibility and
// the choices for anything else.
VisibilityMode parse_visibility_mode(const std::string& text);

struct VisibilityChoice {
  VisibilityMode mode = VisibilityMode::None;  // resolved: None, Rays or Exact (never Auto)
  std::string reason;                          // "requested (--visibility rays)" or "auto: <why>", for the summary
  std::string name() const;                    // "none", "rays" or "exact"
};

// The mode `requested` resolves to for `scene` (Auto decided as above).
VisibilityChoice choose_visibility(const Scene& scene, VisibilityMode requested);

// The visibility object of a choice: null for None.
std::unique_ptr<Visibility> make_visibility(const Scene& scene, const VisibilityChoice& choice);

}  // namespace photometria
