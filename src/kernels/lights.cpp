#include "kernels/lights.h"

#include <cmath>

#include "kernels/distant.h"
#include "kernels/sphere.h"
#include "util/error.h"

namespace photometria {
namespace {

using nlohmann::json;

[[noreturn]] void fail(const std::string& where, const std::string& msg) { throw_bad_input(where + ": " + msg); }

Vec3 read_vec3(const json& j, const char* key, const std::string& where) {
  if (!j.contains(key)) fail(where, std::string("'") + key + "' is missing");
  const json& v = j[key];
  if (!v.is_array() || v.size() != 3)
    fail(where, std::string("'") + key + "' must be an array of 3 numbers, got " + v.dump());
  Vec3 out;
  for (int i = 0; i < 3; ++i) {
    if (!v[i].is_number() || !std::isfinite(v[i].get<double>()))
      fail(where, std::string("'") + key + "' must be an array of 3 finite numbers, got " + v.dump());
    out[i] = v[i].get<double>();
  }
  return out;
}

double read_number(const json& j, const char* key, const std::string& where) {
  if (!j.contains(key)) fail(where, std::string("'") + key + "' is missing");
  const json& v = j[key];
  if (!v.is_number() || !std::isfinite(v.get<double>()))
    fail(where, std::string("'") + key + "' must be a finite number, got " + v.dump());
  return v.get<double>();
}

Eigen::Array3d read_intensity(const json& j, const std::string& where) {
  if (!j.contains("intensity")) fail(where, "'intensity' is missing");
  const json& v = j["intensity"];
  Eigen::Array3d out;
  if (v.is_number()) {
    out.setConstant(v.get<double>());
  } else if (v.is_array() && v.size() == 3 && v[0].is_number() && v[1].is_number() && v[2].is_number()) {
    for (int i = 0; i < 3; ++i) out[i] = v[i].get<double>();
  } else {
    fail(where, "'intensity' must be a number or [r, g, b], got " + v.dump());
  }
  if (!out.isFinite().all() || (out < 0).any()) fail(where, "'intensity' must be finite and >= 0, got " + v.dump());
  return out;
}

void check_keys(const json& j, const std::string& where, std::initializer_list<const char*> allowed) {
  for (const auto& item : j.items()) {
    bool ok = false;
    for (const char* a : allowed) ok = ok || item.key() == a;
    if (!ok) fail(where, "unknown key '" + item.key() + "'");
  }
}

}  // namespace

std::vector<Light> parse_lights(const json& lights, const std::string& file) {
  if (!lights.is_array()) throw_bad_input(file + ": 'lights' must be an array");
  std::vector<Light> out;
  for (size_t i = 0; i < lights.size(); ++i) {
    const std::string where = file + ": lights[" + std::to_string(i) + "]";
    const json& j = lights[i];
    if (!j.is_object()) fail(where, "must be an object, got " + j.dump());
    if (!j.contains("type") || !j["type"].is_string()) fail(where, "'type' must be \"sphere\" or \"distant\"");
    const std::string type = j["type"].get<std::string>();
    Light light;
    light.intensity = read_intensity(j, where);
    if (type == "sphere") {
      check_keys(j, where, {"type", "center", "radius", "intensity"});
      light.type = Light::Type::Sphere;
      light.center = read_vec3(j, "center", where);
      light.radius = read_number(j, "radius", where);
      if (!(light.radius > 0.0)) fail(where, "'radius' must be a positive number, got " + j["radius"].dump());
    } else if (type == "distant") {
      check_keys(j, where, {"type", "direction", "angle", "angle_deg", "intensity", "normalize"});
      light.type = Light::Type::Distant;
      const Vec3 d = read_vec3(j, "direction", where);
      if (d.norm() == 0.0) fail(where, "'direction' must be a non-zero vector");
      light.direction = d.normalized();
      if (j.contains("angle") && j.contains("angle_deg")) fail(where, "give 'angle' or 'angle_deg', not both");
      const char* key = j.contains("angle_deg") ? "angle_deg" : "angle";
      light.angle_deg = j.contains(key) ? read_number(j, key, where) : 0.0;
      if (light.angle_deg < 0.0 || light.angle_deg > 360.0)
        fail(where, std::string("'") + key + "' must be in [0, 360] degrees, got " + j[key].dump());
      if (j.contains("normalize")) {
        if (!j["normalize"].is_boolean())
          fail(where, "'normalize' must be true or false, got " + j["normalize"].dump());
        light.normalize = j["normalize"].get<bool>();
      }
    } else {
      fail(where, "'type' must be \"sphere\" or \"distant\", got \"" + type + "\"");
    }
    out.push_back(light);
  }
  return out;
}

Eigen::Array3d direct_irradiance(const Receiver& receiver, const Light& light) {
  if (light.type == Light::Type::Sphere)
    return sphere_form_factor(receiver, light.center, light.radius) * light.intensity;  // H = F·M
  return distant_irradiance(receiver, light.direction, light.angle_deg, 1.0, light.normalize) * light.intensity;
}

}  // namespace photometria
