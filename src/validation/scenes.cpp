#include "validation/scenes.h"

#include <cmath>

namespace photometria::validation {

Scene two_polygon_scene(const Polygon& first, const Polygon& second) {
  Scene s;
  s.source = "two_polygons";
  int g = 0;
  for (const Polygon* p : {&first, &second}) {
    Face f;
    for (const Vec3& v : *p) {
      f.vertices.push_back(static_cast<int>(s.vertices.size()));
      s.vertices.push_back(v);
    }
    f.group = g;
    f.source_face = g++;
    s.faces.push_back(f);
  }
  s.materials = {Material{"grey", Rgb::Constant(0.5), Rgb::Zero()}};
  s.groups = {"first", "second"};
  return s;
}

Scene unit_cube_scene(double rho, double emission, int emitting_face) {
  Scene s;
  s.source = "unit_cube";
  s.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  const std::vector<std::vector<int>> faces = {{0, 1, 2, 3}, {4, 7, 6, 5}, {0, 4, 5, 1},
                                               {1, 5, 6, 2}, {2, 6, 7, 3}, {3, 7, 4, 0}};
  s.materials = {Material{"walls", Rgb::Constant(rho), Rgb::Constant(emitting_face < 0 ? emission : 0.0)},
                 Material{"emitter", Rgb::Constant(rho), Rgb::Constant(emission)}};
  for (int f = 0; f < 6; ++f) s.faces.push_back({faces[f], f == emitting_face ? 1 : 0, f, f});
  s.groups = {"floor", "ceiling", "wall_y0", "wall_x1", "wall_y1", "wall_x0"};
  return s;
}

Scene sphere_cap_scene(int rings, double rho) {
  Scene s;
  s.source = "sphere_cap";
  const int segments = 2 * rings;
  // Vertex (ring k, segment m): polar angle θ_k = π k / rings, azimuth φ_m = 2π m / segments.
  auto index = [&](int k, int m) {
    if (k == 0) return 0;
    if (k == rings) return 1 + (rings - 1) * segments;
    return 1 + (k - 1) * segments + (m % segments);
  };
  s.vertices.emplace_back(0, 0, 1);
  for (int k = 1; k < rings; ++k)
    for (int m = 0; m < segments; ++m) {
      const double t = M_PI * k / rings, p = 2 * M_PI * m / segments;
      s.vertices.emplace_back(std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t));
    }
  s.vertices.emplace_back(0, 0, -1);
  s.materials = {Material{"sphere", Rgb::Constant(rho), Rgb::Zero()},
                 Material{"cap", Rgb::Constant(rho), Rgb::Constant(1.0)}};
  s.groups = {"sphere", "cap"};
  for (int k = 0; k < rings; ++k)
    for (int m = 0; m < segments; ++m) {
      // Inward facing: counter-clockwise seen from the centre.
      std::vector<int> v;
      if (k == 0) v = {index(0, 0), index(1, m + 1), index(1, m)};
      else if (k == rings - 1) v = {index(k, m), index(k, m + 1), index(rings, 0)};
      else v = {index(k, m), index(k, m + 1), index(k + 1, m + 1), index(k + 1, m)};
      const bool cap = 3 * (k + 1) <= rings;  // band entirely within θ <= π/3, i.e. z >= 0.5
      s.faces.push_back({v, cap ? 1 : 0, cap ? 1 : 0, static_cast<int>(s.faces.size())});
    }
  return s;
}

}  // namespace photometria::validation
