// Form factor from a receiver point to a spherical cap of directions (a sphere light, or a
// distant light's cone), exact whether the cap is wholly above, crossing or wholly below the
// receiver's horizon.
//
// A cap of half-angle σ around the unit axis A, seen by a receiver with unit normal N, with
// sin β = N·A (β = elevation of the axis above the horizon, α = π/2 − β its angle to N):
//   wholly above (β >= σ):   F = sin²σ sin β            (Heitz 2017 sec. 4, eqs. 14–16)
//   wholly below (β <= −σ):  F = 0
//   crossing (|β| < σ):      π F = [atan t − t cos²σ] + sin²σ sin β · atan2(R, −sin β cos σ),
//                            R = sqrt((sin σ − sin β)(sin σ + sin β)),  t = R / cos σ.
// The crossing branch is Howell's catalog case B-43 (J. R. Howell, "A Catalog of Radiation Heat
// Transfer Configuration Factors", 3rd ed., differential element to sphere, the partly-visible
// branch; the same closed form as J. M. Snyder, "Area light sources for real-time graphics",
// MSR-TR-96-11, 1996, and S. Lagarde & C. de Rousiers, "Moving Frostbite to PBR", SIGGRAPH 2014
// course notes sec. 4.7.2), rewritten so that no digit is lost:
//   π/2 − asin(cos σ / sin α) = atan2(R, cos σ)          (B-43's acos/asin near 1 replaced),
//   acos(−cot σ cot α)        = atan2(R, −sin β cos σ),
//   cos²β − cos²σ             = (sin σ − sin β)(sin σ + sin β),
//   atan t − t cos²σ          = t sin²σ − (t − atan t), with a series for t − atan t when t < 0.2,
// so a sun-sized cap cut by the horizon keeps ~15 digits (B-43 as printed loses ~8). The
// wholly-above case is E. Heitz, "Geometric Derivation of the Irradiance of Polygonal Lights",
// Unity Technologies research report, 2017, sec. 4.
// Caps wider than a hemisphere (σ > π/2, distant lights of angle > 180°) use the complement:
//   F(σ, A) = 1 − F(π − σ, −A).
#pragma once

#include "kernels/lambert.h"

namespace photometria {

// F of the cap; sin_sigma = sin σ >= 0, cos_sigma = cos σ (negative for σ > π/2),
// sin_beta = N·A in [−1, 1]. Dimensionless, in [0, 1]. σ = 0 gives 0.
double spherical_cap_form_factor(double sin_sigma, double cos_sigma, double sin_beta);

// F(dA → sphere): the sphere (centre, radius > 0, metres) subtends the cap sin σ = r/d around the
// direction of its centre, d = |centre − p| (sin θmax = r/D, "Property 2" of the UsdLux note cited
// in distant.h). Only the part above the receiver's horizon counts. A receiver on or inside the
// sphere (d <= r) gets the limit from outside, σ = π/2: (1 + N·Â)/2 (the query reader refuses
// d < r).
double sphere_form_factor(const Receiver& receiver, const Vec3& center, double radius);

}  // namespace photometria
