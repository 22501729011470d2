// In-memory scenes for unit tests (no loader involved).
#pragma once

#include <cmath>

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

// Appends a closed axis-aligned box [lo, hi] whose every side is an n × n grid of quads, each its
// own face (a meshed room when `inward`, its normals into the box; a meshed solid otherwise).
inline void add_meshed_box(Scene& s, const Vec3& lo, const Vec3& hi, int n, bool inward, int material = 0) {
  const Vec3 size = hi - lo;
  // Each side: origin, two edge vectors u, v with u × v outward.
  const Vec3 x(size.x(), 0, 0), y(0, size.y(), 0), z(0, 0, size.z());
  const Vec3 sides[6][3] = {{lo, y, x}, {lo + z, x, y}, {lo, x, z}, {lo + y, z, x}, {lo, z, y}, {lo + x, y, z}};
  for (const auto& side : sides) {
    const Vec3& o = side[0];
    const Vec3 u = inward ? side[2] : side[1], v = inward ? side[1] : side[2];
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        const int b = static_cast<int>(s.vertices.size());
        s.vertices.push_back(o + u * (double(i) / n) + v * (double(j) / n));
        s.vertices.push_back(o + u * (double(i + 1) / n) + v * (double(j) / n));
        s.vertices.push_back(o + u * (double(i + 1) / n) + v * (double(j + 1) / n));
        s.vertices.push_back(o + u * (double(i) / n) + v * (double(j + 1) / n));
        s.faces.push_back({{b, b + 1, b + 2, b + 3}, material, 0, static_cast<int>(s.faces.size())});
      }
  }
}

// Appends a closed, non-convex solid: a sphere of `rings` × `segments` triangles around `centre`
// whose radius varies as r (1 + bump sin 3t sin 4p) with the polar angle t and azimuth p (a
// scanned object), its triangles outward.
inline void add_bumpy_sphere(Scene& s, const Vec3& centre, double r, int rings, int segments, double bump,
                             int material = 0) {
  const double pi = 3.14159265358979323846;
  const int b = static_cast<int>(s.vertices.size());
  auto point = [&](int i, int j) {
    const double t = pi * i / rings, p = 2 * pi * j / segments;
    const double radius = r * (1 + bump * std::sin(3 * t) * std::sin(4 * p));
    return Vec3(centre.x() + radius * std::sin(t) * std::cos(p), centre.y() + radius * std::sin(t) * std::sin(p),
                centre.z() - radius * std::cos(t));
  };
  s.vertices.push_back(point(0, 0));  // bottom pole
  for (int i = 1; i < rings; ++i)
    for (int j = 0; j < segments; ++j) s.vertices.push_back(point(i, j));
  s.vertices.push_back(point(rings, 0));  // top pole
  const int top = static_cast<int>(s.vertices.size()) - 1;
  auto ring = [&](int i, int j) { return b + 1 + (i - 1) * segments + j % segments; };
  auto add = [&](int x, int y, int z) {
    s.faces.push_back({{x, y, z}, material, 0, static_cast<int>(s.faces.size())});
  };
  for (int j = 0; j < segments; ++j) {
    add(b, ring(1, j + 1), ring(1, j));
    add(top, ring(rings - 1, j), ring(rings - 1, j + 1));
  }
  for (int i = 1; i + 1 < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      add(ring(i, j), ring(i, j + 1), ring(i + 1, j + 1));
      add(ring(i, j), ring(i + 1, j + 1), ring(i + 1, j));
    }
}

}  // namespace builders
