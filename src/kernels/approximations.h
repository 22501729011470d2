// Approximations of the point-to-polygon form factor (O. Lawlor, "Radiosity Units & Computation",
// CS 481/681 lecture notes, University of Alaska Fairbanks, 2007). They are NOT exact: `photometria
// formfactor --kernel <approximation>` prints each value beside the exact one and the error
// (docs/kernels.md has a table of the error against distance). Conventions: vertices
// counter-clockwise seen from the front, receiver behind the polygon's plane gets 0 (one-sided,
// docs/theory.md "Units and conventions"). Unlike the exact kernels none of them clips the polygon
// to the receiver's horizon — that is part of what they approximate — so a polygon partly below the
// horizon can give a value too large, or even negative.
#pragma once

#include "kernels/lambert.h"

namespace photometria {

// Inverse-square point source (Lawlor 2007, "Computing Solid Angles"): the polygon as a point at
// its centroid c with its area A,
//   F ≈ A · max(0, N·ĉ) · max(0, −n_P·ĉ) / (π |c − p|²),
// exact only in the limit distance → ∞; for a unit disk at distance z it gives 1/z² instead of
// the exact 1/(z² + 1) (Lawlor 2007).
double point_source_form_factor(const Receiver& receiver, const Vec3* polygon, int n);

// Hottel–Sarofim / Tampieri vector form exactly as Lawlor 2007 codes it:
//   Φ = Σ_i acos(R̂_i·R̂_{i+1}) normalize(R̂_i × R̂_{i+1}),  R̂_i = normalize(p − v_i),
//   F ≈ −N·Φ/(2π),
// i.e. Lambert's formula (Stark 2000, eq. 3; docs/theory.md "References") without clipping to
// the horizon and with acos of a dot product (loses digits for short edges or a receiver close
// to an edge's line).
double tampieri_form_factor(const Receiver& receiver, const Vec3* polygon, int n);

// Seed 003's cheap cross-product approximation for distant receivers: acos(R̂_i·R̂_{i+1}) ≈
// |R̂_i × R̂_{i+1}| (sin Ω ≈ Ω), so Φ ≈ Σ_i R̂_i × R̂_{i+1} and F ≈ −N·Φ/(2π). Too small up
// close (relative error ≈ Ω²/6 per edge), no clipping.
double cross_product_form_factor(const Receiver& receiver, const Vec3* polygon, int n);

}  // namespace photometria
