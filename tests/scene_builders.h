// In-memory scenes for unit tests (no loader involved).
#pragma once

#include "scene/scene.h"

namespace builders {

using photometria::Scene;
using photometria::Vec3;

// Closed unit cube [0,1]^3 with inward normals, one material, one group. Face order: floor z=0,
// ceiling z=1, wall y=0, wall x=1, wall y=1, wall x=0 (as in refs cube_floor_emitting_rho0.5).
inline Scene unit_cube(double rho = 0.5, double e = 1.0) {
  Scene s;
  s.source = "unit_cube";
  s.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  const std::vector<std::vector<int>> faces = {{0, 1, 2, 3}, {4, 7, 6, 5}, {0, 4, 5, 1},
                                               {1, 5, 6, 2}, {2, 6, 7, 3}, {3, 7, 4, 0}};
  for (size_t f = 0; f < faces.size(); ++f) s.faces.push_back({faces[f], 0, 0, int(f)});
  photometria::Material m;
  m.name = "furnace";
  m.reflectance = photometria::Rgb::Constant(rho);
  m.emission = photometria::Rgb::Constant(e);
  s.materials = {m};
  s.groups = {"cube"};
  return s;
}

// The unit cube with only the floor emitting (two materials: "floor" emits E, "wall" does not).
inline Scene cube_floor_emitting(double rho = 0.5) {
  Scene s = unit_cube(rho, 0.0);
  photometria::Material floor = s.materials[0];
  floor.name = "floor";
  floor.emission = photometria::Rgb::Constant(1.0);
  s.materials[0].name = "wall";
  s.materials.push_back(floor);
  s.faces[0].material = 1;
  return s;
}

// Appends a closed axis-aligned box [lo, hi] with outward normals (an occluder) to the scene.
inline void add_box(Scene& s, const Vec3& lo, const Vec3& hi, int material = 0) {
  const int b = static_cast<int>(s.vertices.size());
  for (int k = 0; k < 8; ++k)
    s.vertices.emplace_back(k & 1 ? hi.x() : lo.x(), k & 2 ? hi.y() : lo.y(), k & 4 ? hi.z() : lo.z());
  // Outward: counter-clockwise seen from outside.
  const std::vector<std::vector<int>> faces = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                               {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : faces) {
    std::vector<int> v;
    for (int k : f) v.push_back(b + k);
    s.faces.push_back({v, material, 0, static_cast<int>(s.faces.size())});
  }
}

}  // namespace builders
