#include "solver/channel.h"

namespace photometria {

void multiply(const FormFactors& F, const Eigen::VectorXd& x, Eigen::VectorXd& y) {
  const int n = static_cast<int>(F.rows());
  y.resize(n);
#pragma omp parallel for schedule(static)
  for (int i = 0; i < n; ++i) y[i] = F.row_dot(i, x);
}

Eigen::VectorXd residual_vector(const ChannelProblem& p, const Eigen::VectorXd& B) {
  Eigen::VectorXd FB;
  multiply(p.F, B, FB);
  // r = E + ρ∘(F B + H) − B  (solver.h, from DESIGN.md's B = E + ρ·H)
  return p.E + p.rho.cwiseProduct(FB + p.H) - B;
}

double relative_norm(const Eigen::VectorXd& r, const Eigen::VectorXd& B) {
  const double bn = B.norm();
  return bn > 0 ? r.norm() / bn : r.norm();
}

}  // namespace photometria
