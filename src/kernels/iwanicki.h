// Iwanicki's form of the point-to-polygon form factor (M. Iwanicki, "Deriving the analytical
// formula for a diffuse response from a polygonal light source", Activision technical note;
// section "Putting it all together", from Stokes' theorem, eqs. 2, 4 and 9):
//
//   F = (1/2π) Σ_i (Ω_i / sin Ω_i) (p̂_i × p̂_{i+1})·n          (Iwanicki, final formula)
//
// with p̂_i the unit directions from the receiver to the vertices and Ω_i = ∠(p̂_i, p̂_{i+1}).
// With unnormalized a_i = v_i − p the term is w_i (a_i × a_{i+1})·n, w_i = Ω_i / |a_i × a_{i+1}|,
// a weight that stays bounded (→ 1/(a_i·a_{i+1})) for short edges (the numerics rules of
// docs/theory.md "Units and conventions").
//
// Evaluation (the project's default kernel, see docs/kernels.md): for a polygon that is small
// against its distance (every vertex within |c|/16 of vertex 0, c = v_0 − p) the sum is
// rearranged exactly with Σ_i e_i = 0 (e_i = v_{i+1} − v_i, a closed polygon):
//
//   Σ w_i a_i × e_i = c × Σ (w_i − w̄) e_i + Σ w_i r_i × e_i,   r_i = v_i − v_0,  w̄ = 1/|c|²,
//
// where w_i − w̄ is formed without cancellation (a series for Ω/tan Ω − 1 and
// a_i·a_{i+1} − |c|² = c·(r_i + r_{i+1}) + r_i·r_{i+1}). Every term is then of the size of the
// result, so F ~ 1e-12 keeps ~15 digits where the plain edge sum keeps ~10. Otherwise the sum is
// evaluated directly, with Ω_i = atan2(|a_i × e_i|, a_i·a_{i+1}).
//
// Same conventions and domain as lambert_form_factor() (clipping, one-sidedness, boundary limit:
// see visible_polygon.h). Result in [0, 1].
#pragma once

#include "kernels/lambert.h"

namespace photometria {

double iwanicki_form_factor(const Receiver& receiver, const Vec3* polygon, int n);

}  // namespace photometria
