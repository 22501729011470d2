// A distant light of angular diameter `angle_deg`: the cone of half-angle θmax = angle_deg/2
// around `direction` (the unit direction *toward* the light), uniform radiance inside.
// Normalization after the OpenUSD UsdLux note "Normalizing Distant Lights – In Depth" (Pixar,
// UsdLux schema documentation; docs/theory.md "References"), cited below as "UsdLux note".
// Geometrically the same spherical cap as a sphere with sin θmax = r/d (UsdLux note,
// "Property 2"),
// so the form factor is spherical_cap_form_factor() (sphere.h), exact above, across and below
// the horizon and for θmax > π/2 (angle_deg > 180).
#pragma once

#include "kernels/lambert.h"

namespace photometria {

// (1/π) ∫_cone max(0, N·ω) dω, dimensionless, in [0, 1]; `direction` need not be unit length
// (non-zero); angle_deg in [0, 360]. angle_deg = 0 gives 0 (a cone of no solid angle).
double distant_form_factor(const Receiver& receiver, const Vec3& direction, double angle_deg);

// UsdLux sizeFactor(θmax) (UsdLux note), θmax = angle_deg/2:
//   1 if θmax = 0;  π sin²θmax if 0 < θmax <= π/2;  π (2 − sin²θmax) if π/2 < θmax <= π.
// With `normalize` on the light's radiance is intensity / sizeFactor (UsdLux note).
double distant_size_factor(double angle_deg);

// Irradiance (W/m², or lux for photometric intensity) from a distant light on the receiver.
//   normalize off: radiance L = intensity;                 E = π F L
//   normalize on:  radiance L = intensity / sizeFactor;    E = π F L
// so that with normalize on and θmax <= π/2 a surface facing the light gets E = intensity
// (UsdLux note, "Property 1"). For θmax > π/2 the note defines sizeFactor from the two-sided
// integral ∫ L |cos θ| dω, so there E = intensity is the two-sided illuminance and the
// one-sided irradiance of a facing surface is intensity / (2 − sin²θmax).
// θmax = 0 is a delta light (sizeFactor = 1): E = intensity · max(0, N·direction).
double distant_irradiance(const Receiver& receiver, const Vec3& direction, double angle_deg, double intensity,
                          bool normalize);

}  // namespace photometria
