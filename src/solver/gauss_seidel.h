// Gauss–Seidel solution of the radiosity system, one colour channel at a time.
//
//   B_i = E_i + ρ_i (Σ_j F_ij B_j + H_direct,i)          (DESIGN.md "Physics conventions")
//
// Sweeps i = 0..N-1 updating B_i in place (Cohen & Greenberg 1985; Cohen & Wallace 1993, §5.3).
// Converges for 0 <= ρ < 1 and row sums Σ_j F_ij <= 1 (the system matrix is strictly diagonally
// dominant). Stops when the relative residual ‖E + ρ∘(F·B + H_direct) − B‖₂ / ‖B‖₂ <= tolerance;
// the (cheap) sweep update norm decides when that residual is worth computing.
#pragma once

#include <Eigen/Core>

#include "formfactors/formfactors.h"

namespace photometria {

using ChannelMatrix = Eigen::Matrix<double, Eigen::Dynamic, 3>;  // N × 3 (RGB), W/m² or unitless

struct SolverOptions {
  double tolerance = 1e-8;     // relative residual to stop at
  int max_iterations = 100000; // sweeps per channel before giving up
};

struct SolverReport {
  int iterations = 0;       // largest number of sweeps over the channels solved
  double residual = 0.0;    // largest final relative residual over the channels
  int channels_solved = 0;  // 1 when every material is grey (channels 1, 2 copied), else 3
  bool converged = false;
};

// Solves for B (N × 3). `grey` = all of E, ρ, H_direct identical across channels: solve one.
// Throws photometria::Error(BadInput) if some ρ is outside [0, 1) or some E < 0.
SolverReport solve_radiosity(const FormFactorMatrix& F, const ChannelMatrix& emission,
                             const ChannelMatrix& reflectance, const ChannelMatrix& direct_irradiance,
                             bool grey, const SolverOptions& options, ChannelMatrix& radiosity);

}  // namespace photometria
