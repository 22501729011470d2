#include "solver/gauss_seidel.h"

namespace photometria {

ChannelResult gauss_seidel_channel(const ChannelProblem& p, const SolverOptions& opt, Eigen::VectorXd& B) {
  const FormFactors& F = p.F;
  B = p.E;  // first guess: emission only
  double residual = relative_norm(residual_vector(p, B), B);
  if (residual <= opt.tolerance) return {0, residual, true, false, ""};
  for (int sweep = 1; sweep <= opt.max_iterations; ++sweep) {
    double update2 = 0.0, norm2 = 0.0;
    gauss_seidel_sweep(F, B, [&](int i, double fb) {
      // B_i = E_i + ρ_i (Σ_j F_ij B_j + H_i)  (Cohen & Wallace 1993, §5.3: Gauss–Seidel, in place)
      const double b = p.E[i] + p.rho[i] * (fb + p.H[i]);
      update2 += (b - B[i]) * (b - B[i]);
      norm2 += b * b;
      return b;
    });
    // The last sweep's update bounds how far B still moves; only then is the true residual checked.
    if (update2 <= opt.tolerance * opt.tolerance * norm2 || sweep == opt.max_iterations) {
      residual = relative_norm(residual_vector(p, B), B);
      if (residual <= opt.tolerance) return {sweep, residual, true, false, ""};
    }
  }
  return {opt.max_iterations, residual, false, false, ""};
}

}  // namespace photometria
