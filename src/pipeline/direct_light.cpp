#include "pipeline/direct_light.h"

namespace photometria {

DirectLighting::DirectLighting(const Scene& scene) {
  if (scene.settings.contains("lights")) lights_ = parse_lights(scene.settings["lights"], scene.source);
  if (lights_.empty()) return;
  Vec3 lo = scene.vertices.at(0), hi = lo;
  for (const Vec3& v : scene.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  far_ = 4.0 * std::max((hi - lo).norm(), 1e-6);
  if (!scene_needs_no_visibility(scene)) rays_ = std::make_unique<RayVisibility>(scene);
}

DirectLighting::~DirectLighting() = default;

Eigen::Array3d DirectLighting::at(const Vec3& point, const Vec3& normal) const {
  Eigen::Array3d h = Eigen::Array3d::Zero();
  for (const Light& light : lights_) {
    const Eigen::Array3d e = direct_irradiance(Receiver{point, normal}, light);
    if ((e == 0.0).all()) continue;
    if (rays_) {
      const Vec3 start = point + 10 * rays_->surface_offset() * normal;
      Vec3 end;
      if (light.type == Light::Type::Sphere) {
        const Vec3 to_centre = light.center - point;
        end = light.center - light.radius * to_centre.normalized();
      } else {
        end = point + far_ * light.direction;
      }
      if (rays_->blocked(start, end)) continue;
    }
    h += e;
  }
  return h;
}

}  // namespace photometria
