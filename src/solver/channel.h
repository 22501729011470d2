// One colour channel of the radiosity system, shared by the solver methods.
//
//   K B = b,  K = I − diag(ρ) F,  b = E + ρ∘H_direct     (DESIGN.md "Physics conventions")
//
// All vectors have N entries (one per patch). F is the N × N row-major form-factor matrix.
#pragma once

#include <Eigen/Core>
#include <string>

#include "formfactors/formfactors.h"

namespace photometria {

struct ChannelProblem {
  const FormFactors& F;  // N × N, row i = receiver
  Eigen::VectorXd E;          // emission, W/m²
  Eigen::VectorXd rho;        // reflectance in [0, 1)
  Eigen::VectorXd H;          // direct irradiance, W/m²
};

struct ChannelResult {
  int iterations = 0;      // sweeps or matrix-vector products
  double residual = 0.0;   // final relative residual (definition in solver.h)
  bool converged = false;
  bool fell_back = false;  // cg only: finished with gmres
  std::string detail;
};

// y = F x, rows split over the OpenMP threads (a dense product is memory bound; one pass over F).
void multiply(const FormFactors& F, const Eigen::VectorXd& x, Eigen::VectorXd& y);

// r = E + ρ∘(F B + H) − B (one pass over F).
Eigen::VectorXd residual_vector(const ChannelProblem& p, const Eigen::VectorXd& B);

// ‖r‖₂ / ‖B‖₂ (‖r‖₂ when B = 0).
double relative_norm(const Eigen::VectorXd& r, const Eigen::VectorXd& B);

}  // namespace photometria
