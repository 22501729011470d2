// Form-factor assembly: F_ij from patch i to patch j for every pair of patches.
//
//   F_ij = Σ_q w_q F(dA_{x_q} -> P_j) · V_ij
// with F(dA -> P) Lambert's closed form (kernels/lambert.h), x_q, w_q the receiver quadrature on
// patch i (formfactors/quadrature.h) and V_ij the visible fraction (visibility/visibility.h; 1
// when visibility is off). Pairs that face away from each other are skipped without evaluation:
// if patch j lies wholly on or below patch i's plane, or patch i wholly on or behind patch j's
// plane, F_ij = 0 (one-sided emission and reception).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>

#include "patching/patching.h"
#include "visibility/visibility.h"

namespace photometria {

// Dense N × N, row i = receiver patch i. Row-major so that a Gauss–Seidel sweep reads rows.
using FormFactorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct FillOptions {
  int quadrature = 1;                        // receiver rule order (1 = centroid)
  const RayVisibility* visibility = nullptr; // null: no occlusion test
  int rays = 16;                             // segments per pair when visibility is on
  uint64_t seed = 1;                         // ray sampling seed (results repeat for a seed)
  std::function<void(double)> progress;      // called with the fraction done (from one thread)
};

struct FillStats {
  long long pairs_evaluated = 0;   // pairs whose kernel was evaluated
  long long pairs_backfacing = 0;  // skipped: facing away or coplanar
  long long pairs_occluded = 0;    // evaluated, then found fully blocked
  long long rays_cast = 0;
};

// True when the pair (receiver i, source j) cannot exchange light: j on/below i's plane or i
// on/behind j's plane (with a tolerance of `tol` metres).
bool facing_away(const PatchMesh& mesh, int i, int j, double tol);

FormFactorMatrix fill_form_factors(const PatchMesh& mesh, const FillOptions& options, FillStats& stats);

// Geometric tolerance for plane tests: a few ulps of the scene's size.
double plane_tolerance(const PatchMesh& mesh);

}  // namespace photometria
