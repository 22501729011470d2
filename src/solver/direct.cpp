#include "solver/direct.h"

#include <Eigen/LU>

namespace photometria {

ChannelResult direct_channel(const ChannelProblem& p, const SolverOptions& opt, Eigen::VectorXd& B) {
  // K = I − diag(ρ) F  (direct.h; from B = E + ρ(F B + H), docs/theory.md)
  Eigen::MatrixXd K = -(p.rho.asDiagonal() * p.F.to_dense());
  K.diagonal().array() += 1.0;
  const Eigen::PartialPivLU<Eigen::MatrixXd> lu(K);  // Golub & Van Loan Alg. 3.4.1
  K.resize(0, 0);
  B = lu.solve(p.E + p.rho.cwiseProduct(p.H));
  Eigen::VectorXd r = residual_vector(p, B);
  double rel = relative_norm(r, B);
  int steps = 1;
  for (; rel > opt.tolerance && steps < 3; ++steps) {  // iterative refinement (G&VL §3.5.3)
    B += lu.solve(r);
    r = residual_vector(p, B);
    rel = relative_norm(r, B);
  }
  return {steps, rel, rel <= opt.tolerance, false, ""};
}

}  // namespace photometria
