// One colour channel of the radiosity system, shared by the solver methods.
//
//   K B = b,  K = I − diag(ρ) F,  b = E + ρ∘H_direct     (docs/theory.md "Units and conventions")
//
// All vectors have N entries (one per patch). F is the N × N row-major form-factor matrix.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <string>

#include "formfactors/formfactors.h"

namespace photometria {

struct ChannelProblem {
  const FormFactors& F;  // N × N, row i = receiver
  Eigen::VectorXd E;     // emission, W/m²
  Eigen::VectorXd rho;   // reflectance in [0, 1)
  Eigen::VectorXd H;     // direct irradiance, W/m²
};

struct ChannelResult {
  int iterations = 0;     // sweeps or matrix-vector products
  double residual = 0.0;  // final relative residual (definition in solver.h)
  bool converged = false;
  bool fell_back = false;  // cg only: finished with gmres
  std::string detail;
};

// y = F x, rows split over the OpenMP threads (a dense product is memory bound; one pass over F).
void multiply(const FormFactors& F, const Eigen::VectorXd& x, Eigen::VectorXd& y);

// One sweep in Gauss–Seidel order: for i = 0 .. N−1 in turn, B_i = new_value(i, s_i) with
// s_i = Σ_j F_ij B_j, where B_j (j < i) is already this sweep's value and B_j (j >= i) the last
// one's. new_value is called in that order on one thread at a time.
// The same iteration as updating row after row, at both cores' memory bandwidth (a dense sweep is
// a pass over F, memory bound): rows go in blocks of kSweepBlock; the part of a block's rows
// outside the block's own columns depends only on B values that are final for this block, so it
// is summed first with the rows split over the OpenMP threads, then the block's rows are updated
// in order, adding their in-block part. Each row is summed by one thread in a fixed order, so the
// result does not depend on the thread count.
constexpr int kSweepBlock = 256;
void gauss_seidel_sweep(const FormFactors& F, Eigen::VectorXd& B, const std::function<double(int, double)>& new_value);

// r = E + ρ∘(F B + H) − B (one pass over F).
Eigen::VectorXd residual_vector(const ChannelProblem& p, const Eigen::VectorXd& B);

// ‖r‖₂ / ‖B‖₂ (‖r‖₂ when B = 0).
double relative_norm(const Eigen::VectorXd& r, const Eigen::VectorXd& B);

}  // namespace photometria
