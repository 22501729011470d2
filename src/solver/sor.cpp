#include "solver/sor.h"

#include <algorithm>
#include <cmath>

namespace photometria {

double young_omega(const FormFactors& F, const Eigen::VectorXd& rho) {
  const int n = static_cast<int>(F.rows());
  double mu = 0.0;
#pragma omp parallel for schedule(static) reduction(max : mu)
  for (int i = 0; i < n; ++i) {
    const double fii = F(i, i), off = F.row_sum(i) - fii;
    mu = std::max(mu, rho[i] * off / (1.0 - rho[i] * fii));  // Gershgorin bound on the Jacobi matrix
  }
  if (mu <= 0.0) return 1.0;
  mu = std::min(mu, 1.0);
  return 2.0 / (1.0 + std::sqrt(1.0 - mu * mu));  // Young 1954: ω_b, sor.h
}

ChannelResult sor_channel(const ChannelProblem& p, double omega, const SolverOptions& opt, Eigen::VectorXd& B) {
  const FormFactors& F = p.F;
  B = p.E;
  double residual = relative_norm(residual_vector(p, B), B);
  if (residual <= opt.tolerance) return {0, residual, true, false, ""};
  for (int sweep = 1; sweep <= opt.max_iterations; ++sweep) {
    double update2 = 0.0, norm2 = 0.0;
    gauss_seidel_sweep(F, B, [&](int i, double fb) {
      const double fii = F(i, i);
      // Gauss–Seidel value, then over-relaxed (sor.h; Young 1954, SOR)
      const double g = (p.E[i] + p.rho[i] * (fb - fii * B[i] + p.H[i])) / (1.0 - p.rho[i] * fii);
      const double b = B[i] + omega * (g - B[i]);
      update2 += (b - B[i]) * (b - B[i]);
      norm2 += b * b;
      return b;
    });
    if (update2 <= opt.tolerance * opt.tolerance * norm2 || sweep == opt.max_iterations) {
      residual = relative_norm(residual_vector(p, B), B);
      if (residual <= opt.tolerance) return {sweep, residual, true, false, ""};
    }
  }
  return {opt.max_iterations, residual, false, false, ""};
}

}  // namespace photometria
