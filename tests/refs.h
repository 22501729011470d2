// Access to the analytic reference values (tests/data/refs_public.json: Howell's closed forms in
// 100-digit arithmetic, checked by an independent method): decimal strings parsed as long double.
#pragma once

#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "geometry/polygon.h"

namespace refs {

inline const nlohmann::json& all() {
  static const nlohmann::json data = [] {
    std::ifstream in(std::string(PHOTOMETRIA_SOURCE_DIR) + "/tests/data/refs_public.json");
    return nlohmann::json::parse(in);
  }();
  return data;
}

inline const nlohmann::json& find(const std::string& id) {
  for (const auto& c : all()["cases"])
    if (c["id"] == id) return c;
  throw std::runtime_error("no reference case " + id);
}

inline long double number(const nlohmann::json& v) { return std::stold(v.get<std::string>()); }

inline photometria::Vec3 vec(const nlohmann::json& v) {
  return {v[0].get<double>(), v[1].get<double>(), v[2].get<double>()};
}

inline photometria::Polygon polygon(const nlohmann::json& v) {
  photometria::Polygon p;
  for (const auto& x : v) p.push_back(vec(x));
  return p;
}

}  // namespace refs
