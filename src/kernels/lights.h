// Analytic lights of a scene file (docs/usage.md "Input formats", `lights`): spheres and
// distant lights, and the direct irradiance they give a receiver point
// (H_direct in B = E + ρ(F B + H_direct)).
//
// Scene-file syntax (top-level "lights" array, copied to settings["lights"] by the loader):
//   {"type": "sphere",  "center": [x, y, z], "radius": r, "intensity": M}
//   {"type": "distant", "direction": [x, y, z], "angle": deg, "intensity": I, "normalize": false}
// intensity: one number or [r, g, b]. "angle_deg" is accepted for "angle".
//
// Units (docs/theory.md "Units and conventions"): a sphere's intensity is its emitted exitance
// M (W/m²; radiance M/π), so H = F · M with F = sphere_form_factor(). A distant light's
// intensity is its radiance as in the OpenUSD UsdLux note "Normalizing Distant Lights – In
// Depth" (see distant.h): H = π F L with L = intensity, or intensity / sizeFactor when normalize
// is on (then a surface facing the light receives H = intensity for angle <= 180°). See distant.h.
// No shadowing: the light is seen unoccluded (occlusion of direct light is the caller's job).
#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "kernels/lambert.h"

namespace photometria {

struct Light {
  enum class Type { Sphere, Distant };
  Type type = Type::Sphere;
  Eigen::Array3d intensity = Eigen::Array3d::Zero();  // RGB, see units above
  // sphere
  Vec3 center = Vec3::Zero();  // metres
  double radius = 0.0;         // metres, > 0
  // distant
  Vec3 direction = Vec3::UnitZ();  // unit, toward the light
  double angle_deg = 0.0;          // angular diameter, degrees, in [0, 360]; 0 = delta light
  bool normalize = false;          // UsdLux normalize (distant.h)
};

// Reads a "lights" array. Errors (photometria::Error, BadInput) name `file`, the light index and
// the value at fault, e.g. "scene.json: lights[1]: 'radius' must be a positive number".
std::vector<Light> parse_lights(const nlohmann::json& lights, const std::string& file);

// Direct irradiance (RGB, W/m²) on the receiver from one light, unoccluded.
Eigen::Array3d direct_irradiance(const Receiver& receiver, const Light& light);

}  // namespace photometria
