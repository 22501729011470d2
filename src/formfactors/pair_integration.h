// Patch-to-patch form factors to a requested accuracy, chosen per pair.
//
//   F_ij = (1/A_i) ∫_{A_i} F(dA_x → P_j) dA_x
// with the inner factor exact (Lambert, kernels/lambert.h), so only the receiver integral is
// approximated. Per pair:
//  1. The receiver is clipped to the source's front half-space first: points behind P_j's plane
//     see nothing, and leaving them in would put a kink in the integrand (one-sidedness) that no
//     polynomial rule integrates well. The clipped region is convex.
//  2. Far pairs (distance d from the receiver's centre to the source's bounding sphere large
//     against the receiver's half-size h): fixed n × n Gauss–Legendre, n from the convergence
//     rate of Gauss quadrature for an integrand analytic in a Bernstein ellipse of parameter
//     ρ = a + sqrt(a² − 1), a = d/h (Trefethen, "Is Gauss quadrature better than Clenshaw–Curtis?",
//     SIAM Review 50 (2008), Thm 4.5: error = O(ρ^{-2n})): n = ceil(ln(10/τ) / (2 ln ρ)).
//  3. Near and touching pairs (sharing an edge or a vertex, where the integrand has an
//     x·log x singularity at the shared feature): adaptive, anisotropic bisection of the
//     receiver's parameter domain with a 4 × 4 Gauss rule per cell; each cell is split in the
//     direction whose halves change the estimate most, so refinement runs towards a shared edge
//     in O(log 1/τ) cells instead of filling the edge with small squares.
#pragma once

#include "geometry/polygon.h"

namespace photometria {

enum class PairRule { Skipped, Gauss, Adaptive };

struct PairResult {
  double form_factor = 0.0;
  PairRule rule = PairRule::Skipped;
  int order = 0;              // Gauss order (points per direction) for PairRule::Gauss
  long long evaluations = 0;  // kernel evaluations spent
};

// F(receiver → source) to relative tolerance `tolerance` (absolute floor: tolerance × 1e-4).
// Polygons: 3 or 4 corners, convex, planar, counter-clockwise seen from their fronts.
PairResult pair_form_factor(const Vec3* receiver, int receiver_count, const Vec3& receiver_normal, const Vec3* source,
                            int source_count, const Vec3& source_normal, double tolerance);

}  // namespace photometria
