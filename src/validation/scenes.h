// Analytic reference scenes built in memory for the validation suite.
#pragma once

#include "scene/scene.h"

namespace photometria::validation {

// A scene of two planar polygons (front faces as given), groups 0 and 1, one grey material.
Scene two_polygon_scene(const Polygon& first, const Polygon& second);

// Closed unit cube [0,1]^3, inward normals, faces in the order floor z=0, ceiling z=1, walls
// y=0, x=1, y=1, x=0; material 0 for every face except `emitting_face` (material 1, emits E).
// emitting_face = -1: every face uses material 0 (set E and ρ there: a white furnace).
Scene unit_cube_scene(double rho, double emission, int emitting_face);

// A closed UV sphere of radius 1 facing inward with `rings` latitude bands (a multiple of 3 so
// that z = 0.5 is a ring) and 2·rings longitudes; the faces with z >= 0.5 (the polar cap, a
// quarter of the true sphere's area) use material 1 emitting E = 1, the rest material 0; ρ
// uniform. Quads between rings (planar isosceles trapezoids) and triangles at the poles.
Scene sphere_cap_scene(int rings, double rho);

}  // namespace photometria::validation
