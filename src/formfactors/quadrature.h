// Receiver quadrature on a patch: points and weights for averaging a point kernel over the patch.
//
//   F_ij = (1/A_i) ∫_{A_i} F(dA_x -> P_j) dA_x  ≈  Σ_q w_q F(dA_{x_q} -> P_j),   Σ_q w_q = 1
//
// order 1: the patch centroid (Baum, Rushmeier & Winget 1989, the point-collocation rule).
// order n >= 2: Gauss–Legendre n × n points (Abramowitz & Stegun 25.4.29), mapped bilinearly on
// quads (with the map's Jacobian in the weights) and through the collapsed (Duffy) square-to-
// triangle map on triangles, so that polynomials of degree 2n − 1 are integrated exactly.
#pragma once

#include <vector>

#include "geometry/polygon.h"

namespace photometria {

struct QuadraturePoint {
  Vec3 point;
  double weight;  // normalised: the weights of one patch sum to 1
};

// Gauss–Legendre nodes and weights on [0, 1] (n >= 1).
void gauss_legendre_unit(int n, std::vector<double>& nodes, std::vector<double>& weights);

// Quadrature points on a triangle or quad patch (3 or 4 vertices).
std::vector<QuadraturePoint> patch_quadrature(const Vec3* corners, int corner_count, int order);

}  // namespace photometria
