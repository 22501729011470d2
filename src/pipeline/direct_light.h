// Direct irradiance from a scene file's analytic lights (spheres and distant lights).
//
//   H_direct(x) = Σ_lights direct_irradiance(x, light) · S(x, light)
// with direct_irradiance() the exact unoccluded value (kernels/lights.h: sphere form factor incl.
// the horizon-crossing case, Howell B-43; distant cone with the normalization of the OpenUSD UsdLux
// note "Normalizing Distant Lights – In Depth", see kernels/distant.h) and S ∈ {0, 1} a hard shadow
// test: one segment from x towards the light's centre (sphere: to its near surface point; distant:
// along the direction out of the scene). Partial shadowing of an extended light by an occluder is
// not resolved (documented in docs/theory.md). Shadow rays are cast only when some face can block
// (scene_needs_no_visibility is false).
#pragma once

#include <memory>
#include <vector>

#include "kernels/lights.h"
#include "scene/scene.h"
#include "visibility/visibility.h"

namespace photometria {

class DirectLighting {
 public:
  // Reads scene.settings["lights"] (errors name the scene file and the light index).
  explicit DirectLighting(const Scene& scene);
  ~DirectLighting();

  bool empty() const { return lights_.empty(); }
  int count() const { return static_cast<int>(lights_.size()); }
  bool casts_shadow_rays() const { return rays_ != nullptr; }

  // RGB irradiance (W/m²) at a surface point with unit normal `normal`.
  Eigen::Array3d at(const Vec3& point, const Vec3& normal) const;

 private:
  std::vector<Light> lights_;
  std::unique_ptr<RayVisibility> rays_;
  double far_ = 1.0;  // a length beyond the scene, metres
};

}  // namespace photometria
