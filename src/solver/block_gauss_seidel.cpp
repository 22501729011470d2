#include "solver/block_gauss_seidel.h"

#include <cmath>

namespace photometria {

double block_relative_residual(const RowBlock& block, const Eigen::VectorXd& E, const Eigen::VectorXd& rho,
                               const Eigen::VectorXd& H, const Eigen::VectorXd& B, const SumOverProcesses& sum) {
  std::vector<double> r2 = {0.0};
  for (size_t k = 0; k < block.rows.size(); ++k) {
    const int i = block.rows[k];
    const double r = E[i] + rho[i] * (block.F.row(Eigen::Index(k)).dot(B) + H[i]) - B[i];
    r2[0] += r * r;
  }
  sum(r2);
  const double bn = B.norm();
  return bn > 0 ? std::sqrt(r2[0]) / bn : std::sqrt(r2[0]);
}

ChannelResult block_gauss_seidel_channel(const RowBlock& block, const Eigen::VectorXd& E, const Eigen::VectorXd& rho,
                                         const Eigen::VectorXd& H, const SolverOptions& opt,
                                         const SumOverProcesses& sum, Eigen::VectorXd& B) {
  const Eigen::Index n = E.size();
  B = E;  // first guess: emission only
  std::vector<double> exchange(size_t(n) + 2);
  auto relative_residual = [&] { return block_relative_residual(block, E, rho, H, B, sum); };
  double residual = relative_residual();
  if (residual <= opt.tolerance) return {0, residual, true, false, ""};
  for (int sweep = 1; sweep <= opt.max_iterations; ++sweep) {
    double update2 = 0.0, norm2 = 0.0;
    std::fill(exchange.begin(), exchange.end(), 0.0);
    for (size_t k = 0; k < block.rows.size(); ++k) {
      const int i = block.rows[k];
      // B_i = E_i + ρ_i (Σ_j F_ij B_j + H_i)  (Cohen & Wallace 1993, §5.3: Gauss–Seidel, in place)
      const double b = E[i] + rho[i] * (block.F.row(Eigen::Index(k)).dot(B) + H[i]);
      update2 += (b - B[i]) * (b - B[i]);
      norm2 += b * b;
      B[i] = b;
      exchange[size_t(i)] = b;
    }
    exchange[size_t(n)] = update2;
    exchange[size_t(n) + 1] = norm2;
    sum(exchange);  // every row is some process's: the sums are the new B
    for (Eigen::Index i = 0; i < n; ++i) B[i] = exchange[size_t(i)];
    update2 = exchange[size_t(n)];
    norm2 = exchange[size_t(n) + 1];
    // The sweep's update bounds how far B still moves; only then is the true residual checked.
    if (update2 <= opt.tolerance * opt.tolerance * norm2 || sweep == opt.max_iterations) {
      residual = relative_residual();
      if (residual <= opt.tolerance) return {sweep, residual, true, false, ""};
    }
  }
  return {opt.max_iterations, residual, false, false, ""};
}

}  // namespace photometria
