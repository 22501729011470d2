#include "solver/channel.h"

#include <algorithm>

namespace photometria {

void multiply(const FormFactors& F, const Eigen::VectorXd& x, Eigen::VectorXd& y) {
  const int n = static_cast<int>(F.rows());
  y.resize(n);
#pragma omp parallel for schedule(static)
  for (int i = 0; i < n; ++i) y[i] = F.row_dot(i, x);
}

void gauss_seidel_sweep(const FormFactors& F, Eigen::VectorXd& B, const std::function<double(int, double)>& new_value) {
  const int n = static_cast<int>(F.rows());
  double outside[kSweepBlock];
#pragma omp parallel if (n > kSweepBlock)
  for (int r0 = 0; r0 < n; r0 += kSweepBlock) {
    const int r1 = std::min(n, r0 + kSweepBlock);
    // Columns before the block hold this sweep's values, columns after it the last sweep's.
#pragma omp for schedule(static)
    for (int i = r0; i < r1; ++i) outside[i - r0] = F.row_dot(i, B, 0, r0) + F.row_dot(i, B, r1, n);
      // (the implied barrier: every outside sum is in before the block's rows change B)
#pragma omp single
    for (int i = r0; i < r1; ++i) B[i] = new_value(i, outside[i - r0] + F.row_dot(i, B, r0, r1));
  }
}

Eigen::VectorXd residual_vector(const ChannelProblem& p, const Eigen::VectorXd& B) {
  Eigen::VectorXd FB;
  multiply(p.F, B, FB);
  // r = E + ρ∘(F B + H) − B  (solver.h, from B = E + ρ·H, docs/theory.md)
  return p.E + p.rho.cwiseProduct(FB + p.H) - B;
}

double relative_norm(const Eigen::VectorXd& r, const Eigen::VectorXd& B) {
  const double bn = B.norm();
  return bn > 0 ? r.norm() / bn : r.norm();
}

}  // namespace photometria
