// Occluded configurations with exact answers by superposition of Howell's closed form, for the
// visibility tests (tests/test_visibility_*.cpp).
#pragma once

#include <cmath>
#include <vector>

#include "geometry/polygon.h"

namespace vis_configs {

using photometria::Polygon;
using photometria::Vec3;

// Howell's catalogue, case B-3 (refs_public.json "pp_B3_*"): differential planar element to a
// parallel rectangle whose corner lies on the element's normal, F = 1/(2π)[X/√(1+X²)
// atan(Y/√(1+X²)) + Y/√(1+Y²) atan(X/√(1+Y²))], X = a/c, Y = b/c. Odd in X and in Y.
inline double howell_b3(double x, double y) {
  const double sx = std::sqrt(1 + x * x), sy = std::sqrt(1 + y * y);
  return (x / sx * std::atan(y / sx) + y / sy * std::atan(x / sy)) / (2 * M_PI);
}

// F from the origin (normal +z) to the rectangle [x1,x2] × [y1,y2] in the plane z = h, by
// superposition of four corner rectangles (signed, since howell_b3 is odd in each argument).
inline double rect(double x1, double x2, double y1, double y2, double h) {
  return howell_b3(x2 / h, y2 / h) - howell_b3(x1 / h, y2 / h) - howell_b3(x2 / h, y1 / h) + howell_b3(x1 / h, y1 / h);
}

// Axis-aligned rectangle at height z, wound to face down (-z) or up (+z).
inline Polygon rect_poly(double x1, double x2, double y1, double y2, double z, bool down = true) {
  if (down) return {{x1, y1, z}, {x1, y2, z}, {x2, y2, z}, {x2, y1, z}};
  return {{x1, y1, z}, {x2, y1, z}, {x2, y2, z}, {x1, y2, z}};
}

// Rectangle in the plane x = x0 spanning [y1,y2] × [z1,z2], facing -x.
inline Polygon wall_x(double x0, double y1, double y2, double z1, double z2) {
  return {{x0, y1, z1}, {x0, y1, z2}, {x0, y2, z2}, {x0, y2, z1}};
}

}  // namespace vis_configs

#include "scene/scene.h"

namespace vis_configs {

// A scene whose faces are the given polygons (one material, one group), for the ray engine and
// the culler.
inline photometria::Scene scene_of(const std::vector<Polygon>& polygons) {
  photometria::Scene s;
  s.source = "test";
  for (const Polygon& p : polygons) {
    photometria::Face f;
    for (const Vec3& v : p) {
      f.vertices.push_back(int(s.vertices.size()));
      s.vertices.push_back(v);
    }
    f.source_face = int(s.faces.size());
    s.faces.push_back(f);
  }
  s.materials = {photometria::Material{}};
  s.groups = {"test"};
  return s;
}

}  // namespace vis_configs
