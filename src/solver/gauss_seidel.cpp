#include "solver/gauss_seidel.h"

#include <cmath>
#include <sstream>

#include "util/error.h"

namespace photometria {
namespace {

void check_inputs(const ChannelMatrix& E, const ChannelMatrix& rho) {
  for (int i = 0; i < E.rows(); ++i)
    for (int c = 0; c < 3; ++c) {
      if (!(rho(i, c) >= 0.0 && rho(i, c) < 1.0)) {
        std::ostringstream s;
        s << "patch " << i << ": reflectance " << rho(i, c) << " (channel " << c
          << ") must be in [0, 1) or the solution does not converge";
        throw_bad_input(s.str());
      }
      if (!(E(i, c) >= 0.0) || !std::isfinite(E(i, c))) {
        std::ostringstream s;
        s << "patch " << i << ": emission " << E(i, c) << " (channel " << c << ") must be finite and >= 0";
        throw_bad_input(s.str());
      }
    }
}

// r = E + ρ∘(F·B + H) − B, relative 2-norm.
double relative_residual(const FormFactorMatrix& F, const Eigen::VectorXd& E, const Eigen::VectorXd& rho,
                         const Eigen::VectorXd& H, const Eigen::VectorXd& B) {
  const Eigen::VectorXd r = E + rho.cwiseProduct(F * B + H) - B;
  const double bn = B.norm();
  return bn > 0 ? r.norm() / bn : r.norm();
}

struct ChannelResult { int iterations; double residual; bool converged; };

ChannelResult solve_channel(const FormFactorMatrix& F, const Eigen::VectorXd& E, const Eigen::VectorXd& rho,
                            const Eigen::VectorXd& H, const SolverOptions& opt, Eigen::VectorXd& B) {
  const int n = static_cast<int>(E.size());
  B = E;  // first guess: emission only
  double residual = relative_residual(F, E, rho, H, B);
  if (residual <= opt.tolerance) return {0, residual, true};
  for (int sweep = 1; sweep <= opt.max_iterations; ++sweep) {
    double update2 = 0.0, norm2 = 0.0;
    for (int i = 0; i < n; ++i) {
      const double b = E[i] + rho[i] * (F.row(i).dot(B) + H[i]);
      update2 += (b - B[i]) * (b - B[i]);
      norm2 += b * b;
      B[i] = b;
    }
    // The last sweep's update bounds how far B still moves; only then is the true residual checked.
    if (update2 <= opt.tolerance * opt.tolerance * norm2 || sweep == opt.max_iterations) {
      residual = relative_residual(F, E, rho, H, B);
      if (residual <= opt.tolerance) return {sweep, residual, true};
    }
  }
  return {opt.max_iterations, residual, false};
}

}  // namespace

SolverReport solve_radiosity(const FormFactorMatrix& F, const ChannelMatrix& E, const ChannelMatrix& rho,
                             const ChannelMatrix& H, bool grey, const SolverOptions& options, ChannelMatrix& B) {
  check_inputs(E, rho);
  const int n = static_cast<int>(E.rows());
  B.resize(n, 3);
  SolverReport report;
  report.channels_solved = grey ? 1 : 3;
  report.converged = true;
  for (int c = 0; c < report.channels_solved; ++c) {
    Eigen::VectorXd b;
    const ChannelResult r = solve_channel(F, E.col(c), rho.col(c), H.col(c), options, b);
    B.col(c) = b;
    report.iterations = std::max(report.iterations, r.iterations);
    report.residual = std::max(report.residual, r.residual);
    report.converged = report.converged && r.converged;
  }
  for (int c = report.channels_solved; c < 3; ++c) B.col(c) = B.col(0);
  return report;
}

}  // namespace photometria
