// The radiosity solve: pick a method, solve each colour channel, report what ran.
//
//   B_i = E_i + ρ_i (Σ_j F_ij B_j + H_direct,i)          (docs/theory.md "Units and conventions")
//
// i.e. the linear system K B = E + ρ∘H_direct with K = I − diag(ρ) F (N × N, one per channel).
// Every method stops on the same relative residual
//   ‖E + ρ∘(F·B + H_direct) − B‖₂ / ‖B‖₂ <= tolerance,
// evaluated with the true F (never a symmetrised or approximated one) before it reports success.
//
// Methods (one file each in src/solver/):
//   gauss-seidel  in-place sweeps (gauss_seidel.cpp). The default for non-stiff scenes.
//   sor           successive over-relaxation with Young's ω (sor.cpp).
//   cg            conjugate gradients on the area-weighted symmetric formulation
//                 diag(A/ρ) − diag(A)·F, with refinement against the true, only approximately
//                 reciprocal F and a GMRES fallback (cg.cpp). Needs patch areas.
//   gmres         restarted GMRES on K itself (gmres.cpp): no symmetry or areas needed.
//   direct        Eigen LU of K (direct.cpp): the reference for small N.
//   auto          choose_method() below.
#pragma once

#include <Eigen/Core>
#include <string>

#include "formfactors/formfactors.h"

namespace photometria {

using ChannelMatrix = Eigen::Matrix<double, Eigen::Dynamic, 3>;  // N × 3 (RGB), W/m² or unitless

enum class SolverMethod { Auto, GaussSeidel, Sor, Cg, Gmres, Direct };

// "auto", "gauss-seidel", "sor", "cg", "gmres", "direct".
const char* method_name(SolverMethod m);
// Inverse of method_name; throws photometria::Error(BadInput) naming the bad value.
SolverMethod parse_method(const std::string& name);

struct SolverOptions {
  double tolerance = 1e-8;      // relative residual to stop at
  int max_iterations = 100000;  // per channel: sweeps (gauss-seidel, sor) or matrix-vector
                                // products (cg, gmres) before giving up
  SolverMethod method = SolverMethod::Auto;
  double omega = 0.0;             // sor relaxation factor in (0, 2); 0 = Young's estimate (sor.h)
  Eigen::VectorXd areas = {};     // N patch areas, m²; empty = unknown (then cg is unavailable)
  int direct_max_patches = 8192;  // direct refuses larger N (it copies and factors N × N)
};

struct SolverReport {
  int iterations = 0;       // largest over the channels: sweeps (gauss-seidel, sor), passes over F
                            // (cg, gmres: products incl. residual checks), LU solves (direct)
  double residual = 0.0;    // largest final relative residual over the channels
  int channels_solved = 0;  // 1 when every material is grey (channels 1, 2 copied), else 3
  bool converged = false;
  SolverMethod method = SolverMethod::GaussSeidel;  // what produced B (never Auto)
  double seconds = 0.0;                             // wall time of the solve (all channels)
  double omega = 0.0;                               // sor: the relaxation factor used (largest over channels); else 0
  double reciprocity_error = -1.0;  // cg: ‖S − Sᵀ‖_F / ‖S‖_F, S = diag(A)F; −1 = not measured
  std::string detail;               // one line: how the method went (restarts, fallback), may be empty
};

// The method `auto` runs, from the largest reflectance over all channels and the patch count:
//   max ρ <= 0.9          -> gauss-seidel (non-stiff: the design default; see docs/performance.md)
//   else N <= 64          -> direct (a tiny dense LU is exact and instant)
//   else                  -> gmres
// cg is never chosen automatically: quadrature form factors are not reciprocal (the centroid rule
// is ~7% off in ‖S − Sᵀ‖/‖S‖ on a meshed cube), so cg pays for refinement or falls back to gmres,
// and gmres was faster in every measured case (docs/performance.md "Solvers"). `areas_known` is
// kept so that a reciprocal fill can opt back in.
SolverMethod choose_method(double max_reflectance, int patches, bool areas_known);

// Solves for B (N × 3). `grey`: the caller expects E, ρ and H_direct to be identical across the
// channels; one channel is solved (and copied) only when they are, so a wrong claim costs time,
// never a wrong channel (report.channels_solved says which was done).
// Throws photometria::Error(BadInput) if some ρ is outside [0, 1), some E < 0, cg is asked for
// without options.areas (or areas of the wrong size / not > 0), or direct for N > direct_max_patches.
SolverReport solve_radiosity(const FormFactors& F, const ChannelMatrix& emission, const ChannelMatrix& reflectance,
                             const ChannelMatrix& direct_irradiance, bool grey, const SolverOptions& options,
                             ChannelMatrix& radiosity);

}  // namespace photometria
