#include "visibility/choice.h"

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

VisibilityChoice choose_visibility(const Scene& scene, VisibilityMode requested) {
  VisibilityChoice c;
  c.mode = requested;
  switch (requested) {
    case VisibilityMode::None: c.reason = "requested (--visibility none)"; return c;
    case VisibilityMode::Rays: c.reason = "requested (--visibility rays)"; return c;
    case VisibilityMode::Exact: c.reason = "requested (--visibility exact)"; return c;
    case VisibilityMode::Auto: break;
  }
  std::string why;
  const std::string faces = std::to_string(scene.faces.size()), limit = std::to_string(kAutoExactMaxFaces);
  if (scene_needs_no_visibility(scene, &why)) {
    c.mode = VisibilityMode::None;
    c.reason = "auto: " + why;
  } else if (scene.faces.size() <= kAutoExactMaxFaces) {
    c.mode = VisibilityMode::Exact;
    c.reason = "auto: " + why + "; " + faces + " faces <= " + limit + ", so exact clipping";
  } else {
    c.mode = VisibilityMode::Rays;
    c.reason = "auto: " + why + "; " + faces + " faces > " + limit + ", so rays";
  }
  return c;
}

std::unique_ptr<Visibility> make_visibility(const Scene& scene, const VisibilityChoice& choice) {
  if (choice.mode == VisibilityMode::None) return nullptr;
  return std::make_unique<Visibility>(
      scene, choice.mode == VisibilityMode::Exact ? VisibilityMethod::Exact : VisibilityMethod::Rays);
}

}  // namespace photometria
